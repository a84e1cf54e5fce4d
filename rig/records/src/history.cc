#include "odocal/records/history.h"

#include <algorithm>
#include <iterator>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "odocal/base/format.h"

namespace odocal::records {
namespace {

using nlohmann::json;

constexpr double kSecondsPerWeek = 7.0 * 86400.0;
// d2 for a moving range of two: the mean |x_i - x_{i-1}| of a normal process is 1.128 sigma.
constexpr double kD2 = 1.128;

struct Point {
  double x = 0.0;
  double y = 0.0;
  std::optional<double> sigma;
};

// A weighted least-squares line, kept about its (weighted) centroid so the intercept and the
// slope are uncorrelated: the prediction's variance is scale (1/sum_w + (x - xm)^2 / sxx).
struct LineFit {
  int n = 0;
  bool weighted = false;  // every point had a sigma: weights 1/sigma^2
  double xm = 0.0, ym = 0.0, slope = 0.0;
  double sum_w = 0.0, sxx = 0.0;
  // What the covariance is multiplied by: the reduced chi^2 when it is above 1 (the points
  // scatter more than their sigmas say), the residual variance with unit weights.
  double scale = 1.0;
  bool has_sigma = false;  // unit weights need a residual (n > 2) to say anything
  int dof = 0;
  double scatter = 0.0;    // the residuals' RMS about the line (n - 2 degrees of freedom)

  double At(double x) const { return ym + slope * (x - xm); }
  double VarianceAt(double x) const { return scale * (1.0 / sum_w + (x - xm) * (x - xm) / sxx); }
  double SlopeSigma() const { return std::sqrt(scale / sxx); }
};

std::optional<LineFit> FitLine(const std::vector<Point>& given) {
  // Points without a sigma beside three or more with one (a UMBMark calibration that kept the
  // believed scale among trajectory fits): the weighted line of those with one. Unit weights for
  // all would let the unknown points set the scatter, and drop every known sigma.
  std::vector<Point> known;
  std::copy_if(given.begin(), given.end(), std::back_inserter(known), [](const Point& p) { return p.sigma && *p.sigma > 0.0; });
  const std::vector<Point>& points = known.size() >= 3 ? known : given;
  LineFit f;
  f.n = static_cast<int>(points.size());
  if (f.n < 2) return std::nullopt;
  f.weighted = std::all_of(points.begin(), points.end(), [](const Point& p) { return p.sigma && *p.sigma > 0.0; });
  auto weight = [&](const Point& p) { return f.weighted ? 1.0 / (*p.sigma * *p.sigma) : 1.0; };
  for (const Point& p : points) {
    f.sum_w += weight(p);
    f.xm += weight(p) * p.x;
    f.ym += weight(p) * p.y;
  }
  f.xm /= f.sum_w;
  f.ym /= f.sum_w;
  double sxy = 0.0;
  for (const Point& p : points) {
    f.sxx += weight(p) * (p.x - f.xm) * (p.x - f.xm);
    sxy += weight(p) * (p.x - f.xm) * (p.y - f.ym);
  }
  if (!(f.sxx > 0.0)) return std::nullopt;  // all at one time: no slope
  f.slope = sxy / f.sxx;
  double chi2 = 0.0, ssr = 0.0;
  for (const Point& p : points) {
    const double r = p.y - f.At(p.x);
    chi2 += weight(p) * r * r;
    ssr += r * r;
  }
  f.dof = f.n - 2;
  if (f.dof > 0) f.scatter = std::sqrt(ssr / f.dof);
  if (f.weighted) {
    f.has_sigma = true;
    if (f.dof > 0) f.scale = std::max(1.0, chi2 / f.dof);
  } else if (f.dof > 0) {
    f.has_sigma = true;
    f.scale = chi2 / f.dof;
  }
  return f;
}

// What a trend says a value at x should be, with the variance of that prediction including the
// segment's scatter about its line. Unit weights need two degrees of freedom for the scatter to
// mean anything (one residual can be zero by chance and would make any change a "step").
struct Prediction {
  double value = 0.0;
  double variance = 0.0;
};
std::optional<Prediction> PredictFromTrend(const std::vector<Point>& points, double x) {
  const auto fit = FitLine(points);
  if (!fit || !fit->has_sigma || (!fit->weighted && fit->dof < 2)) return std::nullopt;
  return Prediction{fit->At(x), fit->VarianceAt(x) + fit->scatter * fit->scatter};
}

std::optional<Estimate> SlopeEstimate(const std::vector<Point>& points) {
  const auto fit = FitLine(points);
  if (!fit) return std::nullopt;
  Estimate e{fit->slope, std::nullopt};
  if (fit->has_sigma) e.sigma = fit->SlopeSigma();
  return e;
}

// A calibration: a record with a calibrated set and a time, what the trends are fitted to.
struct Calibration {
  int record = 0;
  double time_s = 0.0;
  double weeks = 0.0;  // since the first calibration
  Estimate diameter;
  Estimate track;
  std::optional<double> distance_km;
};

struct Parameter {
  const char* name;
  const char* unit;
  Estimate Calibration::*field;
};
constexpr Parameter kParameters[] = {
    {"track_mm", "mm", &Calibration::track},
    {"mean_wheel_diameter_mm", "mm", &Calibration::diameter},
};

std::vector<Point> Points(const std::vector<Calibration>& cals, size_t from, size_t to, const Parameter& p) {
  std::vector<Point> out;
  for (size_t k = from; k < to && k < cals.size(); ++k) {
    const Estimate& e = cals[k].*(p.field);
    out.push_back({cals[k].weeks, e.value, e.sigma});
  }
  return out;
}

// The value at calibration i from the slope the parameter's segments before i share (each at its
// own level: the weighted line with one intercept per segment), taken from the level of the
// segment i is in. Needs the current segment to have a point and the whole to leave a residual.
std::optional<Prediction> PredictFromSegments(const std::vector<Calibration>& cals, const std::vector<size_t>& starts,
                                              size_t i, const Parameter& p) {
  struct Group {
    std::vector<Point> points;
    double sum_w = 0.0, xm = 0.0, ym = 0.0;
  };
  std::vector<Group> groups;
  for (size_t s = 0; s < starts.size(); ++s)
    groups.push_back({Points(cals, starts[s], s + 1 < starts.size() ? starts[s + 1] : i, p), 0.0, 0.0, 0.0});
  size_t total = 0;
  bool weighted = true;
  for (const Group& g : groups)
    for (const Point& q : g.points) {
      ++total;
      weighted = weighted && q.sigma && *q.sigma > 0.0;
    }
  const int dof = static_cast<int>(total) - static_cast<int>(groups.size()) - 1;
  if (groups.back().points.empty() || dof < (weighted ? 1 : 2)) return std::nullopt;
  auto w = [&](const Point& q) { return weighted ? 1.0 / (*q.sigma * *q.sigma) : 1.0; };
  double sxx = 0.0, sxy = 0.0;
  for (Group& g : groups) {
    for (const Point& q : g.points) {
      g.sum_w += w(q);
      g.xm += w(q) * q.x;
      g.ym += w(q) * q.y;
    }
    if (g.sum_w <= 0.0) continue;
    g.xm /= g.sum_w;
    g.ym /= g.sum_w;
    for (const Point& q : g.points) {
      sxx += w(q) * (q.x - g.xm) * (q.x - g.xm);
      sxy += w(q) * (q.x - g.xm) * (q.y - g.ym);
    }
  }
  if (!(sxx > 0.0)) return std::nullopt;
  const double slope = sxy / sxx;
  double chi2 = 0.0, ssr = 0.0;
  for (const Group& g : groups)
    for (const Point& q : g.points) {
      const double r = q.y - g.ym - slope * (q.x - g.xm);
      chi2 += w(q) * r * r;
      ssr += r * r;
    }
  const double scale = weighted ? std::max(1.0, chi2 / dof) : chi2 / dof;
  const Group& g = groups.back();
  const double x = cals[i].weeks;
  return Prediction{g.ym + slope * (x - g.xm),
                    scale * (1.0 / g.sum_w + (x - g.xm) * (x - g.xm) / sxx) + ssr / dof};
}

double TimeOf(const Record& r) {
  return ParseUtc(r.time_utc).value_or(-std::numeric_limits<double>::infinity());
}

// Decimals that show a value to its sigma ("72.012 +/- 0.004"): the sigma's first digit, two
// when that digit is 1 or 2 (0.0015 rounded to 0.002 would misstate it by a third).
int DecimalsFor(double sigma, int fallback) {
  if (!(sigma > 0.0) || !std::isfinite(sigma)) return fallback;
  int d = -static_cast<int>(std::floor(std::log10(sigma)));
  const double lead = sigma * std::pow(10.0, d);
  if (lead < 2.95) ++d;
  return std::clamp(d, 0, 9);
}

std::string ValueText(const Estimate& e, int fallback_decimals) {
  if (!e.sigma) return Fixed(e.value, fallback_decimals);
  const int d = DecimalsFor(*e.sigma, fallback_decimals);
  return Fixed(e.value, d) + " +/- " + Fixed(*e.sigma, d);
}
std::string ValueText(const std::optional<Estimate>& e, int fallback_decimals) {
  return e ? ValueText(*e, fallback_decimals) : std::string("-");
}

template <typename T>
json OrNull(const std::optional<T>& v) {
  return v ? json(*v) : json(nullptr);
}

// "E_max,syst after 2.61 mm > 2 mm" -> "E_max,syst after": the words before the first number
// (or before "not measured"), so a limit exceeded and a limit not measured count as one cause.
std::string LimitKind(const std::string& failed) {
  std::istringstream words(failed);
  std::string word, kind;
  while (words >> word) {
    char* end = nullptr;
    std::strtod(word.c_str(), &end);
    if (word == "not" || (end == word.c_str() + word.size() && end != word.c_str())) break;
    kind += (kind.empty() ? "" : " ") + word;
  }
  return kind.empty() ? failed : kind;
}

std::string Pad(const std::string& s, size_t width) { return s.size() >= width ? s + " " : s + std::string(width - s.size(), ' '); }

// How many calibrations a segment needs before its own trend predicts the next one, and how many
// of the next ones the backward test (the very first calibrations) fits its trend to.
constexpr size_t kMinTrend = 3, kBackwardWindow = 8;

// The records that hold a calibrated set and a time, oldest first, with their weeks since the first.
std::vector<Calibration> CalibrationsOf(const std::vector<Record>& records) {
  std::vector<Calibration> cals;
  for (size_t i = 0; i < records.size(); ++i) {
    const Record& r = records[i];
    const auto t = ParseUtc(r.time_utc);
    if (!r.after || !t) continue;
    Calibration c;
    c.record = static_cast<int>(i);
    c.time_s = *t;
    c.diameter = r.after->MeanWheelDiameterMm();
    c.track = r.after->track_mm;
    c.distance_km = r.distance_km;
    cals.push_back(c);
  }
  if (cals.empty()) return cals;
  for (Calibration& c : cals) c.weeks = (c.time_s - cals.front().time_s) / kSecondsPerWeek;
  return cals;
}

// Calibration i of parameter p against what the segment it is in predicts (see FindSteps): a
// step when it is more than step_z sigmas off, which then starts a new segment.
void TestForStep(const std::vector<Calibration>& cals, size_t i, const Parameter& p, const HistoryOptions& options,
                 std::vector<size_t>& starts, HistoryAnalysis& a) {
  const size_t n = cals.size();
  const size_t segment = starts.back();
  const Estimate& now = cals[i].*(p.field);
  const Estimate& before = cals[i - 1].*(p.field);
  std::optional<Prediction> pred;
  double observed = now.value, observed_sigma = now.sigma.value_or(0.0), change = 0.0;
  if (i - segment >= kMinTrend) pred = PredictFromTrend(Points(cals, segment, i, p), cals[i].weeks);
  if (!pred) pred = PredictFromSegments(cals, starts, i, p);
  if (pred) change = now.value - pred->value;
  if (!pred && n - i >= kMinTrend) {
    pred = PredictFromTrend(Points(cals, i, std::min(n, i + kBackwardWindow), p), cals[i - 1].weeks);
    observed = before.value;
    observed_sigma = before.sigma.value_or(0.0);
    if (pred) change = pred->value - before.value;
  }
  if (!pred && before.sigma) {
    pred = Prediction{before.value, *before.sigma * *before.sigma};
    observed = now.value;
    observed_sigma = now.sigma.value_or(0.0);
    change = now.value - before.value;
  }
  if (!pred) return;
  const double variance = observed_sigma * observed_sigma + pred->variance;
  if (!(variance > 0.0)) return;
  const double z = std::fabs(observed - pred->value) / std::sqrt(variance);
  if (z > options.step_z) {
    a.steps.push_back(Step{cals[i].record, a.records[cals[i].record].time_utc, p.name, change, z});
    starts.push_back(i);
  }
}

// Steps, parameter by parameter (a track repair leaves the wheels' wear trend whole): each
// calibration against the trend of its segment. A segment with no trend of its own yet (its
// first calibrations after a step) is predicted by the slope the earlier segments share, from
// its own level; with no earlier segment either (the very first calibrations) it is tested
// backwards, the calibration before against the trend of the next few. The previous value alone
// is the last resort: it would call a robot that wears four of its sigmas between calibrations
// a repair every time. Returns each parameter's segment starts (indices into cals).
std::vector<std::vector<size_t>> FindSteps(const std::vector<Calibration>& cals, const HistoryOptions& options,
                                           HistoryAnalysis& a) {
  std::vector<std::vector<size_t>> starts(std::size(kParameters), std::vector<size_t>{0});
  for (size_t i = 1; i < cals.size(); ++i)
    for (size_t q = 0; q < std::size(kParameters); ++q) TestForStep(cals, i, kParameters[q], options, starts[q], a);
  return starts;
}

// E_max,syst's growth rates: what a calibration found the robot drifted to, from what the one
// before left it at (0 when that one did not measure it), over the weeks between.
std::vector<Point> EmaxGrowthRates(const std::vector<Record>& records) {
  std::vector<Point> rates;  // x unused: a weighted mean
  int previous = -1;
  for (size_t i = 0; i < records.size(); ++i) {
    const Record& r = records[i];
    const auto t = ParseUtc(r.time_utc);
    if (!t) continue;
    if (previous >= 0 && r.emax_syst_before_mm) {
      const Record& p = records[previous];
      const double weeks = (*t - *ParseUtc(p.time_utc)) / kSecondsPerWeek;
      if (weeks > 0.0) {
        const double start = p.emax_syst_after_mm ? p.emax_syst_after_mm->value : 0.0;
        Point rate{0.0, (r.emax_syst_before_mm->value - start) / weeks, std::nullopt};
        if (r.emax_syst_before_mm->sigma && (!p.emax_syst_after_mm || p.emax_syst_after_mm->sigma))
          rate.sigma = std::hypot(*r.emax_syst_before_mm->sigma, p.emax_syst_after_mm ? *p.emax_syst_after_mm->sigma : 0.0) / weeks;
        rates.push_back(rate);
      }
    }
    if (r.after) previous = static_cast<int>(i);
  }
  return rates;
}

// The rates' weighted mean (weights 1/sigma^2 when every rate has a sigma), its sigma scaled by
// the reduced chi^2 when that is above 1. rates is not empty.
Estimate MeanGrowth(const std::vector<Point>& rates) {
  const bool weighted =
      std::all_of(rates.begin(), rates.end(), [](const Point& p) { return p.sigma && *p.sigma > 0.0; });
  double sw = 0.0, swy = 0.0;
  for (const Point& p : rates) {
    const double w = weighted ? 1.0 / (*p.sigma * *p.sigma) : 1.0;
    sw += w;
    swy += w * p.y;
  }
  Estimate growth{swy / sw, std::nullopt};
  const int m = static_cast<int>(rates.size());
  double chi2 = 0.0;
  for (const Point& p : rates)
    chi2 += (weighted ? 1.0 / (*p.sigma * *p.sigma) : 1.0) * (p.y - growth.value) * (p.y - growth.value);
  if (weighted)
    growth.sigma = std::sqrt((m > 1 ? std::max(1.0, chi2 / (m - 1)) : 1.0) / sw);
  else if (m > 1)
    growth.sigma = std::sqrt(chi2 / (m - 1) / sw);
  return growth;
}

// When the robot is due: the last calibration + recalibrate_days, or the day E_max,syst's growth
// reaches its limit if sooner.
void SetDue(const Calibration& last, const HistoryOptions& options, HistoryAnalysis& a) {
  const Record& last_record = a.records[last.record];
  std::optional<double> due_s;
  if (options.limits.recalibrate_days) due_s = last.time_s + *options.limits.recalibrate_days * 86400.0;
  if (options.limits.emax_syst_after_mm && a.emax_growth_mm_per_week && a.emax_growth_mm_per_week->value > 0.0) {
    const double start = last_record.emax_syst_after_mm ? last_record.emax_syst_after_mm->value : 0.0;
    const double weeks = std::max(0.0, (*options.limits.emax_syst_after_mm - start) / a.emax_growth_mm_per_week->value);
    const double crossing = last.time_s + weeks * kSecondsPerWeek;
    a.limit_crossing_utc = FormatUtc(crossing);
    due_s = due_s ? std::min(*due_s, crossing) : crossing;
  }
  if (due_s) {
    a.due_utc = FormatUtc(*due_s);
    a.due = *due_s <= options.now_s;
  }
}

// The newest calibration against the trend of the ones before it in its segment (a step at
// the newest already says it: no warning twice).
void WarnIfNewestDisagrees(const std::vector<Calibration>& cals, const std::vector<std::vector<size_t>>& starts,
                           const HistoryOptions& options, HistoryAnalysis& a) {
  const size_t n = cals.size();
  const Calibration& last = cals.back();
  const Record& last_record = a.records[last.record];
  const bool newest_stepped =
      std::any_of(a.steps.begin(), a.steps.end(), [&](const Step& s) { return s.index == last.record; });
  for (size_t q = 0; q < std::size(kParameters) && n >= 2 && !newest_stepped; ++q) {
    const Parameter& p = kParameters[q];
    const size_t segment = starts[q].back();
    if (n - 1 - segment < kMinTrend) continue;
    {
      const Estimate& now = last.*(p.field);
      const auto pred = PredictFromTrend(Points(cals, segment, n - 1, p), last.weeks);
      if (!pred) continue;
      const double variance = std::pow(now.sigma.value_or(0.0), 2) + pred->variance;
      if (!(variance > 0.0)) continue;
      const double z = std::fabs(now.value - pred->value) / std::sqrt(variance);
      if (z <= options.disagree_z) continue;
      const Estimate predicted{pred->value, std::sqrt(pred->variance)};
      a.warnings.push_back(Format("%s: the newest calibration (%s) found %s %s, the trend of the %d before it predicts %s %s "
                                  "(%.1f sigma off): a repair, a wheel change, or a run to check",
                                  p.name, last_record.time_utc.c_str(), ValueText(now, 3).c_str(), p.unit,
                                  static_cast<int>(n - 1 - segment), ValueText(predicted, 3).c_str(), p.unit, z));
    }
  }
}
}  // namespace

HistoryAnalysis AnalyseHistory(const std::string& robot, std::vector<Record> records, const HistoryOptions& options) {
  HistoryAnalysis a;
  a.robot = robot;
  std::stable_sort(records.begin(), records.end(),
                   [](const Record& x, const Record& y) { return TimeOf(x) < TimeOf(y); });
  a.records = std::move(records);

  const std::vector<Calibration> cals = CalibrationsOf(a.records);
  if (cals.empty()) return a;
  const size_t n = cals.size();

  const std::vector<std::vector<size_t>> starts = FindSteps(cals, options, a);
  const size_t segment = starts[1].back();  // the wheels' (what wear is fitted over)
  const size_t track_segment = starts[0].back();
  a.segment_start = cals[segment].record;
  a.track_segment_start = cals[track_segment].record;

  // Trends over each parameter's segment since its last step.
  std::vector<Point> diameter = Points(cals, segment, n, kParameters[1]);
  a.wear_mm_per_week = SlopeEstimate(diameter);
  a.track_mm_per_week = SlopeEstimate(Points(cals, track_segment, n, kParameters[0]));
  std::vector<Point> by_distance;
  for (size_t k = segment; k < n; ++k)
    if (cals[k].distance_km)
      by_distance.push_back({*cals[k].distance_km / 1000.0, cals[k].diameter.value, cals[k].diameter.sigma});
  a.wear_mm_per_1000km = SlopeEstimate(by_distance);

  const std::vector<Point> rates = EmaxGrowthRates(a.records);
  if (!rates.empty()) a.emax_growth_mm_per_week = MeanGrowth(rates);

  SetDue(cals.back(), options, a);
  WarnIfNewestDisagrees(cals, starts, options, a);
  return a;
}

json HistoryJson(const HistoryAnalysis& a) {
  json records = json::array();
  for (const Record& r : a.records) records.push_back(ToJson(r));
  json steps = json::array();
  for (const Step& s : a.steps)
    steps.push_back({{"index", s.index}, {"time_utc", s.time_utc}, {"parameter", s.parameter}, {"change", s.change}, {"z", s.z}});
  return {{"robot", a.robot},
          {"records", records},
          {"analysis",
           {{"segment_start", a.segment_start},
            {"track_segment_start", a.track_segment_start},
            {"wear_mm_per_week", ToJson(a.wear_mm_per_week)},
            {"wear_mm_per_1000km", ToJson(a.wear_mm_per_1000km)},
            {"track_mm_per_week", ToJson(a.track_mm_per_week)},
            {"steps", steps},
            {"emax_growth_mm_per_week", ToJson(a.emax_growth_mm_per_week)},
            {"limit_crossing_utc", OrNull(a.limit_crossing_utc)},
            {"due_utc", OrNull(a.due_utc)},
            {"due", a.due},
            {"warnings", a.warnings}}}};
}

std::string HistoryTable(const HistoryAnalysis& a) {
  std::ostringstream out;
  out << "robot " << a.robot << ": " << a.records.size() << " records\n\n";
  out << Pad("time (UTC)", 22) << Pad("kind", 9) << Pad("mean diameter mm", 22) << Pad("track mm", 20)
      << Pad("Ed", 22) << Pad("Eb", 22) << Pad("E_max,syst before mm", 21) << Pad("E_max,syst after mm", 21) << "verdict\n";
  for (size_t i = 0; i < a.records.size(); ++i) {
    const Record& r = a.records[i];
    const bool step = std::any_of(a.steps.begin(), a.steps.end(), [&](const Step& s) { return s.index == static_cast<int>(i); });
    out << Pad(r.time_utc + (step ? " *" : ""), 22) << Pad(std::string(ToString(r.kind)), 9)
        << Pad(r.after ? ValueText(r.after->MeanWheelDiameterMm(), 3) : "-", 22)
        << Pad(r.after ? ValueText(r.after->track_mm, 2) : "-", 20) << Pad(ValueText(r.ed, 5), 22) << Pad(ValueText(r.eb, 5), 22)
        << Pad(ValueText(r.emax_syst_before_mm, 2), 21) << Pad(ValueText(r.emax_syst_after_mm, 2), 21) << ToString(r.verdict)
        << "\n";
  }
  if (!a.steps.empty()) out << "(* a step: the trend restarts there)\n";
  out << "\n";
  auto line = [&](const std::string& label, const std::string& value) { out << Pad(label, 34) << value << "\n"; };
  line("wear (mean diameter) mm/week", ValueText(a.wear_mm_per_week, 4));
  line("wear mm/1000 km", ValueText(a.wear_mm_per_1000km, 4));
  line("track mm/week", ValueText(a.track_mm_per_week, 4));
  line("trend fitted from", a.segment_start < static_cast<int>(a.records.size()) ? a.records[a.segment_start].time_utc : "-");
  for (const Step& s : a.steps)
    line("step", Format("%s %s %+.3f (%.1f sigma)", s.time_utc.c_str(), s.parameter.c_str(), s.change, s.z));
  line("E_max,syst growth mm/week", ValueText(a.emax_growth_mm_per_week, 3));
  line("E_max,syst limit reached", a.limit_crossing_utc.value_or("-"));
  line("due", a.due_utc ? *a.due_utc + (a.due ? " (DUE NOW)" : "") : "-");
  for (const std::string& w : a.warnings) out << "warning: " << w << "\n";
  return out.str();
}

std::vector<ControlChart::Flag> WesternElectricFlags(const std::vector<double>& values, double mean, double sigma) {
  std::vector<ControlChart::Flag> flags;
  if (!(sigma > 0.0) || !std::isfinite(sigma)) return flags;
  std::vector<double> z(values.size());
  for (size_t i = 0; i < values.size(); ++i) z[i] = (values[i] - mean) / sigma;
  // How many of the `window` points ending at i are beyond `level` on `side` (a window cut
  // short at the start counts what it has).
  auto beyond = [&](size_t i, size_t window, double level, int side) {
    int count = 0;
    for (size_t j = i + 1 > window ? i + 1 - window : 0; j <= i; ++j) count += side * z[j] > level;
    return count;
  };
  for (size_t i = 0; i < z.size(); ++i) {
    const int idx = static_cast<int>(i);
    if (std::fabs(z[i]) > 3.0)
      flags.push_back({idx, 1, Format("rule 1: %.1f sigma %s the mean", std::fabs(z[i]), z[i] > 0 ? "above" : "below")});
    for (int side : {+1, -1}) {
      const char* where = side > 0 ? "above" : "below";
      // The point itself is beyond: the one that completes the pattern is the one flagged.
      if (side * z[i] > 2.0 && beyond(i, 3, 2.0, side) >= 2)
        flags.push_back({idx, 2, Format("rule 2: 2 of the last 3 beyond 2 sigma %s the mean", where)});
      if (side * z[i] > 1.0 && beyond(i, 5, 1.0, side) >= 4)
        flags.push_back({idx, 3, Format("rule 3: 4 of the last 5 beyond 1 sigma %s the mean", where)});
      if (i >= 7 && beyond(i, 8, 0.0, side) == 8)
        flags.push_back({idx, 4, Format("rule 4: 8 in a row %s the mean", where)});
    }
  }
  return flags;
}

FleetSummary SummariseFleet(const std::vector<Record>& all, const HistoryOptions& options) {
  FleetSummary fleet;
  fleet.records = static_cast<int>(all.size());
  std::map<std::string, std::vector<Record>> by_robot;  // sorted by name, each in the input's order
  for (const Record& r : all) by_robot[r.robot].push_back(r);

  std::map<std::string, int> causes;
  struct First {
    double time;
    std::string robot;
    double value;
  };
  const std::pair<const char*, std::optional<Estimate> Record::*> kQuantities[] = {
      {"Ed", &Record::ed},
      {"Eb", &Record::eb},
      {"emax_syst_before_mm", &Record::emax_syst_before_mm},
      {"emax_syst_after_mm", &Record::emax_syst_after_mm},
  };
  std::vector<std::vector<First>> firsts(std::size(kQuantities));

  for (auto& [name, records] : by_robot) {
    HistoryAnalysis a = AnalyseHistory(name, std::move(records), options);
    FleetRobot robot;
    robot.robot = name;
    robot.last = a.records.back();
    robot.calibrations = static_cast<int>(std::count_if(a.records.begin(), a.records.end(), [](const Record& r) { return r.after.has_value(); }));
    robot.wear_mm_per_week = a.wear_mm_per_week;
    robot.due_utc = a.due_utc;
    robot.due = a.due;
    robot.warnings = a.warnings;
    robot.limit_crossing_utc = a.limit_crossing_utc;
    robot.steps = static_cast<int>(a.steps.size());
    // ISO 8601 UTC strings order as their times do.
    if (a.limit_crossing_utc && (!fleet.first_to_cross || *a.limit_crossing_utc < fleet.first_to_cross->second))
      fleet.first_to_cross = std::make_pair(name, *a.limit_crossing_utc);
    if (robot.last.verdict != Verdict::kNone) {
      ++fleet.judged;
      if (robot.last.verdict == Verdict::kPass) ++fleet.passed;
      for (const std::string& f : robot.last.failed_limits) ++causes[LimitKind(f)];
    }
    for (size_t q = 0; q < std::size(kQuantities); ++q)
      for (const Record& r : a.records)
        if (const auto& v = r.*(kQuantities[q].second)) {
          firsts[q].push_back({TimeOf(r), name, v->value});
          break;
        }
    fleet.robots.push_back(std::move(robot));
  }

  for (const auto& [kind, count] : causes) fleet.causes.emplace_back(kind, count);
  std::stable_sort(fleet.causes.begin(), fleet.causes.end(), [](const auto& x, const auto& y) { return x.second > y.second; });

  for (size_t q = 0; q < std::size(kQuantities); ++q) {
    std::vector<First>& points = firsts[q];
    if (points.size() < 2) continue;
    // Build order: the robots as the line made them (their first records' times; by name on a tie,
    // as they came from the map).
    std::stable_sort(points.begin(), points.end(), [](const First& x, const First& y) { return x.time < y.time; });
    ControlChart chart;
    chart.quantity = kQuantities[q].first;
    for (const First& p : points) {
      chart.robots.push_back(p.robot);
      chart.values.push_back(p.value);
    }
    double sum = 0.0, moving = 0.0;
    for (size_t i = 0; i < chart.values.size(); ++i) {
      sum += chart.values[i];
      if (i > 0) moving += std::fabs(chart.values[i] - chart.values[i - 1]);
    }
    chart.mean = sum / chart.values.size();
    chart.sigma = moving / (chart.values.size() - 1) / kD2;
    chart.flags = WesternElectricFlags(chart.values, chart.mean, chart.sigma);
    fleet.charts.push_back(std::move(chart));
  }
  return fleet;
}

json FleetJson(const FleetSummary& fleet) {
  json robots = json::array();
  for (const FleetRobot& r : fleet.robots)
    robots.push_back({{"robot", r.robot},
                      {"last", ToJson(r.last)},
                      {"calibrations", r.calibrations},
                      {"verdict", ToString(r.last.verdict)},
                      {"due", r.due},
                      {"due_utc", OrNull(r.due_utc)},
                      {"limit_crossing_utc", OrNull(r.limit_crossing_utc)},
                      {"steps", r.steps},
                      {"wear_mm_per_week", ToJson(r.wear_mm_per_week)},
                      {"warnings", r.warnings}});
  json causes = json::array();
  for (const auto& [limit, count] : fleet.causes) causes.push_back({{"limit", limit}, {"count", count}});
  json charts = json::array();
  for (const ControlChart& c : fleet.charts) {
    json flags = json::array();
    for (const auto& f : c.flags) flags.push_back({{"index", f.index}, {"rule", f.rule}, {"why", f.why}});
    charts.push_back({{"quantity", c.quantity},
                      {"robots", c.robots},
                      {"values", c.values},
                      {"mean", c.mean},
                      {"sigma", c.sigma},
                      {"ucl", c.mean + 3.0 * c.sigma},
                      {"lcl", c.mean - 3.0 * c.sigma},
                      {"flags", flags}});
  }
  return {{"robots", robots},
          {"first_to_cross", fleet.first_to_cross ? json{{"robot", fleet.first_to_cross->first},
                                                         {"limit_crossing_utc", fleet.first_to_cross->second}}
                                                  : json(nullptr)},
          {"records", fleet.records},
          {"pass_rate", fleet.judged > 0 ? json(static_cast<double>(fleet.passed) / fleet.judged) : json(nullptr)},
          {"judged", fleet.judged},
          {"passed", fleet.passed},
          {"causes", causes},
          {"charts", charts}};
}

std::string FleetTable(const FleetSummary& fleet) {
  std::ostringstream out;
  out << fleet.robots.size() << " robots, " << fleet.records << " records\n\n";
  out << Pad("robot", 18) << Pad("calibrations", 13) << Pad("last (UTC)", 22) << Pad("verdict", 8)
      << Pad("wear mm/week", 24) << "due\n";
  for (const FleetRobot& r : fleet.robots) {
    out << Pad(r.robot, 18) << Pad(std::to_string(r.calibrations), 13) << Pad(r.last.time_utc, 22)
        << Pad(std::string(ToString(r.last.verdict)), 8) << Pad(ValueText(r.wear_mm_per_week, 4), 24)
        << (r.due_utc ? *r.due_utc + (r.due ? " DUE" : "") : "-") << "\n";
    for (const std::string& w : r.warnings) out << "    warning: " << w << "\n";
  }
  out << "\n";
  if (fleet.first_to_cross)
    out << "first to reach the E_max,syst limit: " << fleet.first_to_cross->first << " on "
        << fleet.first_to_cross->second << "\n";
  if (fleet.judged > 0)
    out << Format("passed %d of %d judged (%.1f %%)\n", fleet.passed, fleet.judged, 100.0 * fleet.passed / fleet.judged);
  else
    out << "no verdicts (no limits were given)\n";
  for (const auto& [limit, count] : fleet.causes) out << "  failed: " << Pad(limit, 24) << count << "\n";
  for (const ControlChart& c : fleet.charts) {
    out << "\n" << Format("%s: %zu robots, mean %.6g, sigma %.3g (moving range), limits %.6g .. %.6g\n", c.quantity.c_str(),
                          c.values.size(), c.mean, c.sigma, c.mean - 3.0 * c.sigma, c.mean + 3.0 * c.sigma);
    for (const auto& f : c.flags)
      out << Format("  #%d %s = %.6g: %s\n", f.index + 1, c.robots[f.index].c_str(), c.values[f.index], f.why.c_str());
  }
  return out.str();
}

}  // namespace odocal::records
