// The history and fleet pages: drawn from the JSON documents (HistoryJson, FleetJson), so the page
// shows exactly what `--json` says. One self-contained file each: inline CSS and SVG, no script,
// nothing fetched; the plots scale with the page (viewBox, max-width) from a phone to a desk.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "odocal/base/format.h"
#include "odocal/records/history.h"

namespace odocal::records {
namespace {

using nlohmann::json;

constexpr double kSecondsPerWeek = 7.0 * 86400.0;

std::string Escape(const std::string& text) { return HtmlEscape(text); }

std::string Str(const json& j, const char* key) {
  return j.is_object() && j.contains(key) && j[key].is_string() ? j[key].get<std::string>() : std::string();
}

std::optional<double> Num(const json& j) { return j.is_number() ? std::optional<double>(j.get<double>()) : std::nullopt; }

// {value, sigma} as "72.012 +/- 0.004" (decimals from the sigma), "-" for null.
std::string EstimateText(const json& e, int fallback_decimals) {
  if (!e.is_object() || !e.contains("value") || !e["value"].is_number()) return "-";
  const double v = e["value"].get<double>();
  const auto s = Num(e.value("sigma", json()));
  if (!s || !(*s > 0.0)) return Fixed(v, fallback_decimals);
  int d = -static_cast<int>(std::floor(std::log10(*s)));
  if (*s * std::pow(10.0, d) < 2.95) ++d;
  d = std::clamp(d, 0, 9);
  return Fixed(v, d) + " &plusmn; " + Fixed(*s, d);
}

std::string Date(double seconds) { return FormatUtc(seconds).substr(0, 10); }

// Round tick steps (1, 2, 5 x 10^k) for about `count` ticks over [lo, hi].
std::vector<double> Ticks(double lo, double hi, int count) {
  std::vector<double> ticks;
  if (!(hi > lo)) return ticks;
  const double raw = (hi - lo) / count;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  // Counted in whole steps: adding a step too small for the values' magnitude would never end.
  const double first = std::ceil(lo / step);
  for (int k = 0; k <= 2 * count + 2; ++k) {
    const double t = (first + k) * step;
    if (t > hi + step * 1e-9) break;
    ticks.push_back(std::fabs(t) < step * 1e-9 ? 0.0 : t);
  }
  return ticks;
}

// A plot area in a 800 x 300 viewBox with data ranges mapped onto it.
struct Frame {
  double x0, x1, y0, y1;
  static constexpr double kW = 800, kH = 300, kLeft = 86, kRight = 18, kTop = 16, kBottom = 46;
  double X(double x) const { return kLeft + (x - x0) / (x1 - x0) * (kW - kLeft - kRight); }
  double Y(double y) const { return kH - kBottom - (y - y0) / (y1 - y0) * (kH - kTop - kBottom); }
};

Frame MakeFrame(double xlo, double xhi, double ylo, double yhi) {
  if (!(xhi > xlo)) {
    xlo -= 1.0;
    xhi += 1.0;
  }
  // All values equal (a chart whose sigma is 0) or equal but for rounding: a band around them.
  if (!(yhi - ylo > 1e-9 * std::max(1.0, std::fabs(ylo)))) {
    const double pad = std::max(1e-6, std::fabs(ylo) * 1e-3);
    ylo -= pad;
    yhi += pad;
  }
  const double px = 0.04 * (xhi - xlo), py = 0.08 * (yhi - ylo);
  return Frame{xlo - px, xhi + px, ylo - py, yhi + py};
}

std::string SvgOpen(const std::string& label) {
  return Format("<svg viewBox=\"0 0 %.0f %.0f\" role=\"img\" aria-label=\"%s\">", Frame::kW, Frame::kH, Escape(label).c_str());
}

std::string Line(double x1, double y1, double x2, double y2, const char* cls) {
  return Format("<line class=\"%s\" x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\"/>", cls, x1, y1, x2, y2);
}

std::string YAxis(const Frame& f, const std::string& unit) {
  std::string s;
  for (double t : Ticks(f.y0, f.y1, 5)) {
    s += Line(Frame::kLeft, f.Y(t), Frame::kW - Frame::kRight, f.Y(t), "grid");
    s += Format("<text class=\"tick\" x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\">%.6g</text>", Frame::kLeft - 6, f.Y(t) + 4, t);
  }
  s += Format("<text class=\"unit\" x=\"12\" y=\"%.1f\" transform=\"rotate(-90 12 %.1f)\" text-anchor=\"middle\">%s</text>",
              Frame::kH / 2 - 10, Frame::kH / 2 - 10, Escape(unit).c_str());
  s += Line(Frame::kLeft, Frame::kTop, Frame::kLeft, Frame::kH - Frame::kBottom, "axis");
  s += Line(Frame::kLeft, Frame::kH - Frame::kBottom, Frame::kW - Frame::kRight, Frame::kH - Frame::kBottom, "axis");
  return s;
}

// Dates along the bottom: about five, on whole days.
std::string TimeAxis(const Frame& f) {
  std::string s;
  const double days = (f.x1 - f.x0) / 86400.0;
  const double step_days = std::max(1.0, std::ceil(days / 5.0));
  const double first = std::ceil(f.x0 / 86400.0) * 86400.0;
  for (double t = first; t <= f.x1; t += step_days * 86400.0)
    s += Format("<text class=\"tick\" x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">%s</text>", f.X(t), Frame::kH - Frame::kBottom + 18,
                Date(t).c_str());
  return s;
}

struct TimePoint {
  double t = 0.0, y = 0.0;
  std::optional<double> sigma;
};

// A parameter over time: error bars, the trend (through the segment's weighted centroid with
// the reported slope: the weighted least-squares line passes through it), steps, a limit date.
std::string TimePlot(const std::string& title, const std::string& unit, const std::vector<TimePoint>& points,
                     const std::vector<TimePoint>& segment, std::optional<double> slope_per_week,
                     const std::vector<std::pair<double, std::string>>& marks) {
  if (points.empty()) return "";
  double xlo = points.front().t, xhi = points.front().t;
  double ylo = std::numeric_limits<double>::infinity(), yhi = -ylo;
  for (const TimePoint& p : points) {
    xlo = std::min(xlo, p.t);
    xhi = std::max(xhi, p.t);
    ylo = std::min(ylo, p.y - p.sigma.value_or(0.0));
    yhi = std::max(yhi, p.y + p.sigma.value_or(0.0));
  }
  for (const auto& [t, label] : marks) xhi = std::max(xhi, t), xlo = std::min(xlo, t);
  const Frame f = MakeFrame(xlo, xhi, ylo, yhi);
  std::string s = "<figure><figcaption>" + Escape(title) + "</figcaption>" + SvgOpen(title) + YAxis(f, unit) + TimeAxis(f);
  for (const auto& [t, label] : marks) {
    s += Line(f.X(t), Frame::kTop, f.X(t), Frame::kH - Frame::kBottom, label.rfind("step", 0) == 0 ? "step" : "limit");
    const bool right_half = f.X(t) > Frame::kW / 2;  // the label on the side with room
    s += Format("<text class=\"mark\" x=\"%.1f\" y=\"%.1f\" text-anchor=\"%s\">%s</text>", f.X(t) + (right_half ? -3 : 3),
                Frame::kTop + 10, right_half ? "end" : "start", Escape(label).c_str());
  }
  if (slope_per_week && segment.size() >= 2) {
    const bool weighted = std::all_of(segment.begin(), segment.end(), [](const TimePoint& p) { return p.sigma && *p.sigma > 0; });
    double sw = 0, st = 0, sy = 0;
    for (const TimePoint& p : segment) {
      const double w = weighted ? 1.0 / (*p.sigma * *p.sigma) : 1.0;
      sw += w;
      st += w * p.t;
      sy += w * p.y;
    }
    const double tm = st / sw, ym = sy / sw;
    auto at = [&](double t) { return ym + *slope_per_week * (t - tm) / kSecondsPerWeek; };
    // Over the calibrations it was fitted to: drawn further it would leave the plot's range.
    const double ta = segment.front().t, tb = segment.back().t;
    s += Format("<path class=\"trend\" d=\"M%.1f %.1fL%.1f %.1f\"/>", f.X(ta), f.Y(at(ta)), f.X(tb), f.Y(at(tb)));
  }
  for (const TimePoint& p : points) {
    if (p.sigma) s += Line(f.X(p.t), f.Y(p.y - *p.sigma), f.X(p.t), f.Y(p.y + *p.sigma), "bar");
    s += Format("<circle class=\"pt\" cx=\"%.1f\" cy=\"%.1f\" r=\"3.5\"><title>%s: %.6g</title></circle>", f.X(p.t), f.Y(p.y),
                Escape(FormatUtc(p.t)).c_str(), p.y);
  }
  return s + "</svg></figure>\n";
}

const char* kStyle = R"(<style>
body{font:15px/1.45 system-ui,sans-serif;margin:0 auto;padding:12px;max-width:1200px;color:#222}
h1{font-size:1.4em}h2{font-size:1.15em;margin-top:1.6em}
.wrap{overflow-x:auto}table{border-collapse:collapse;font-size:.9em}
th,td{border-bottom:1px solid #ddd;padding:3px 8px;text-align:left;white-space:nowrap}
td.n{text-align:right;font-variant-numeric:tabular-nums}
tr.due td{background:#fde8e8}tr.step td{background:#fff4d6}
.fail{color:#b00020;font-weight:600}.pass{color:#116611;font-weight:600}
.warn{background:#fff4d6;padding:6px 10px;border-left:4px solid #e0a000;margin:6px 0}
figure{margin:12px 0}figcaption{font-weight:600}
svg{max-width:100%;height:auto;display:block;background:#fff}
svg text{font:12px system-ui,sans-serif;fill:#333}
.grid{stroke:#eee}.axis{stroke:#888}.bar{stroke:#2a5db0;stroke-width:1.2}.pt{fill:#2a5db0}
.trend{stroke:#e07000;stroke-width:2;fill:none;stroke-dasharray:6 4}
.step{stroke:#c08000;stroke-width:1.5;stroke-dasharray:3 3}.limit{stroke:#b00020;stroke-width:1.5;stroke-dasharray:8 4}
.mean{stroke:#2a5db0;stroke-width:1.5}.cl{stroke:#b00020;stroke-dasharray:6 4}.run{stroke:#aac;fill:none}
circle.flag{fill:#d00020}text.flag{fill:#d00020;font-weight:600}
dl{display:grid;grid-template-columns:max-content 1fr;gap:2px 14px}dt{color:#555}dd{margin:0}
@media (max-width:600px){svg text{font-size:20px}body{font-size:14px}}
</style>)";

std::string Page(const std::string& title, const std::string& body) {
  return "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
         "<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\"><title>" +
         Escape(title) + "</title>" + kStyle + "</head><body>\n" + body + "</body></html>\n";
}

std::optional<double> TimeOf(const json& record) { return ParseUtc(Str(record, "time_utc")); }

}  // namespace

std::string HistoryHtml(const HistoryAnalysis& analysis) {
  const json doc = HistoryJson(analysis);
  const json& an = doc["analysis"];
  const json& records = doc["records"];
  const int segment_start = an.value("segment_start", 0), track_segment_start = an.value("track_segment_start", 0);
  std::set<int> step_rows;
  for (const json& s : an["steps"]) step_rows.insert(s.value("index", -1));

  std::vector<TimePoint> diameter, track, diameter_seg, track_seg;
  for (size_t i = 0; i < records.size(); ++i) {
    const json& r = records[i];
    const auto t = TimeOf(r);
    const json& after = r["params_after"];
    if (!t || !after.is_object()) continue;
    const auto l = Num(after["left_wheel_diameter_mm"]["value"]), rr = Num(after["right_wheel_diameter_mm"]["value"]);
    const auto ls = Num(after["left_wheel_diameter_mm"]["sigma"]), rs = Num(after["right_wheel_diameter_mm"]["sigma"]);
    TimePoint d{*t, 0.5 * (l.value_or(0) + rr.value_or(0)), std::nullopt};
    if (ls && rs) d.sigma = 0.5 * std::hypot(*ls, *rs);
    TimePoint k{*t, Num(after["track_mm"]["value"]).value_or(0), Num(after["track_mm"]["sigma"])};
    diameter.push_back(d);
    track.push_back(k);
    if (static_cast<int>(i) >= segment_start) diameter_seg.push_back(d);
    if (static_cast<int>(i) >= track_segment_start) track_seg.push_back(k);
  }
  std::vector<std::pair<double, std::string>> marks;
  for (const json& s : an["steps"])
    if (const auto t = ParseUtc(Str(s, "time_utc"))) marks.emplace_back(*t, "step: " + Str(s, "parameter"));
  std::vector<std::pair<double, std::string>> diameter_marks = marks;
  if (an["limit_crossing_utc"].is_string())
    if (const auto t = ParseUtc(an["limit_crossing_utc"].get<std::string>()))
      diameter_marks.emplace_back(*t, "E_max,syst limit " + Date(*t));

  std::ostringstream b;
  const std::string robot = doc.value("robot", "");
  b << "<h1>Calibration history: " << Escape(robot) << "</h1>\n";
  b << "<dl>";
  auto item = [&](const std::string& k, const std::string& v) { b << "<dt>" << Escape(k) << "</dt><dd>" << v << "</dd>"; };
  item("records", std::to_string(records.size()));
  item("wear (mean wheel diameter)", EstimateText(an["wear_mm_per_week"], 4) + " mm/week");
  if (!an["wear_mm_per_1000km"].is_null()) item("wear per distance", EstimateText(an["wear_mm_per_1000km"], 4) + " mm/1000 km");
  item("track trend", EstimateText(an["track_mm_per_week"], 4) + " mm/week");
  item("E_max,syst growth", EstimateText(an["emax_growth_mm_per_week"], 3) + " mm/week");
  item("E_max,syst limit reached", an["limit_crossing_utc"].is_string() ? Escape(an["limit_crossing_utc"].get<std::string>()) : "-");
  item("due", an["due_utc"].is_string()
                  ? Escape(an["due_utc"].get<std::string>()) + (an.value("due", false) ? " <span class=\"fail\">due now</span>" : "")
                  : "-");
  b << "</dl>\n";
  for (const json& w : an["warnings"]) b << "<p class=\"warn\">" << Escape(w.get<std::string>()) << "</p>\n";
  for (const json& s : an["steps"])
    b << "<p class=\"warn\">step at " << Escape(Str(s, "time_utc")) << ": " << Escape(Str(s, "parameter")) << " changed by "
      << Format("%+.4g", s.value("change", 0.0)) << Format(" (%.1f sigma)", s.value("z", 0.0)) << "</p>\n";

  b << "<h2>Mean wheel diameter</h2>\n"
    << TimePlot("mean wheel diameter (calibrated) over time", "mm", diameter, diameter_seg, Num(an["wear_mm_per_week"].is_object() ? an["wear_mm_per_week"]["value"] : json()), diameter_marks);
  b << "<h2>Track</h2>\n"
    << TimePlot("track (calibrated) over time", "mm", track, track_seg, Num(an["track_mm_per_week"].is_object() ? an["track_mm_per_week"]["value"] : json()), marks);

  b << "<h2>Records</h2>\n<div class=\"wrap\"><table><tr><th>time (UTC)</th><th>kind</th><th>host</th><th>mean diameter mm</th>"
       "<th>track mm</th><th>Ed</th><th>Eb</th><th>E<sub>max,syst</sub> before mm</th><th>E<sub>max,syst</sub> after mm</th>"
       "<th>verdict</th><th>status</th></tr>\n";
  for (size_t i = 0; i < records.size(); ++i) {
    const json& r = records[i];
    const json& after = r["params_after"];
    std::string mean = "-";
    if (after.is_object()) {
      json m = {{"value", 0.5 * (after["left_wheel_diameter_mm"]["value"].get<double>() + after["right_wheel_diameter_mm"]["value"].get<double>())},
                {"sigma", nullptr}};
      const auto ls = Num(after["left_wheel_diameter_mm"]["sigma"]), rs = Num(after["right_wheel_diameter_mm"]["sigma"]);
      if (ls && rs) m["sigma"] = 0.5 * std::hypot(*ls, *rs);
      mean = EstimateText(m, 3);
    }
    const std::string verdict = Str(r, "verdict");
    b << "<tr" << (step_rows.count(static_cast<int>(i)) ? " class=\"step\"" : "") << "><td>" << Escape(Str(r, "time_utc")) << "</td><td>"
      << Escape(Str(r, "kind")) << "</td><td>" << Escape(Str(r, "host")) << "</td><td class=\"n\">" << mean << "</td><td class=\"n\">"
      << (after.is_object() ? EstimateText(after["track_mm"], 2) : "-") << "</td><td class=\"n\">" << EstimateText(r["Ed"], 5)
      << "</td><td class=\"n\">" << EstimateText(r["Eb"], 5) << "</td><td class=\"n\">" << EstimateText(r["emax_syst_before_mm"], 2)
      << "</td><td class=\"n\">" << EstimateText(r["emax_syst_after_mm"], 2) << "</td><td class=\"" << Escape(verdict) << "\">"
      << Escape(verdict);
    for (const json& f : r["failed_limits"]) b << "<br>" << Escape(f.get<std::string>());
    b << "</td><td>" << Escape(Str(r, "status")) << "</td></tr>\n";
  }
  b << "</table></div>\n";
  return Page("odocal history " + robot, b.str());
}

std::string FleetHtml(const FleetSummary& fleet) {
  const json doc = FleetJson(fleet);
  std::ostringstream b;
  b << "<h1>Fleet: " << doc["robots"].size() << " robots, " << doc.value("records", 0) << " records</h1>\n";
  if (doc["pass_rate"].is_number())
    b << "<p>Passed <b>" << doc.value("passed", 0) << "</b> of " << doc.value("judged", 0) << " judged ("
      << Fixed(100.0 * doc["pass_rate"].get<double>(), 1) << " %), by each robot's last record.</p>\n";
  else
    b << "<p>No verdicts: the records were not judged against limits.</p>\n";
  if (!doc["causes"].empty()) {
    b << "<h2>Failure causes</h2>\n<div class=\"wrap\"><table><tr><th>limit</th><th>robots</th></tr>\n";
    for (const json& c : doc["causes"])
      b << "<tr><td>" << Escape(Str(c, "limit")) << "</td><td class=\"n\">" << c.value("count", 0) << "</td></tr>\n";
    b << "</table></div>\n";
  }

  b << "<h2>Robots</h2>\n<div class=\"wrap\"><table><tr><th>robot</th><th>calibrations</th><th>last (UTC)</th><th>verdict</th>"
       "<th>wear mm/week</th><th>due</th><th>warnings</th></tr>\n";
  for (const json& r : doc["robots"]) {
    const bool due = r.value("due", false);
    const std::string verdict = Str(r, "verdict");
    b << "<tr" << (due ? " class=\"due\"" : "") << "><td>" << Escape(Str(r, "robot")) << "</td><td class=\"n\">"
      << r.value("calibrations", 0) << "</td><td>" << Escape(Str(r["last"], "time_utc")) << "</td><td class=\"" << Escape(verdict)
      << "\">" << Escape(verdict);
    for (const json& f : r["last"]["failed_limits"]) b << "<br>" << Escape(f.get<std::string>());
    b << "</td><td class=\"n\">" << EstimateText(r["wear_mm_per_week"], 4) << "</td><td>"
      << (r["due_utc"].is_string() ? Escape(r["due_utc"].get<std::string>()) : "-") << (due ? " <b class=\"fail\">due</b>" : "")
      << "</td><td>";
    for (const json& w : r["warnings"]) b << Escape(w.get<std::string>()) << "<br>";
    b << "</td></tr>\n";
  }
  b << "</table></div>\n";

  if (!doc["charts"].empty()) b << "<h2>Control charts (each robot's first record, in build order)</h2>\n";
  for (const json& c : doc["charts"]) {
    const std::string q = Str(c, "quantity");
    const std::vector<double> values = c["values"].get<std::vector<double>>();
    const double mean = c.value("mean", 0.0), ucl = c.value("ucl", 0.0), lcl = c.value("lcl", 0.0);
    double lo = std::min(lcl, *std::min_element(values.begin(), values.end()));
    double hi = std::max(ucl, *std::max_element(values.begin(), values.end()));
    const Frame f = MakeFrame(0, std::max<double>(1, values.size() - 1), lo, hi);
    std::map<int, std::vector<std::string>> flagged;  // index -> rules
    for (const json& fl : c["flags"]) flagged[fl.value("index", 0)].push_back(std::to_string(fl.value("rule", 0)));
    std::string title = q + Format(": mean %.6g, sigma %.3g, %zu robots", mean, c.value("sigma", 0.0), values.size());
    b << "<figure><figcaption>" << Escape(title) << "</figcaption>" << SvgOpen(title) << YAxis(f, q);
    for (auto [y, cls, label] : {std::tuple{ucl, "cl", "+3σ"}, std::tuple{mean, "mean", "mean"}, std::tuple{lcl, "cl", "−3σ"}}) {
      b << Line(Frame::kLeft, f.Y(y), Frame::kW - Frame::kRight, f.Y(y), cls);
      b << Format("<text class=\"tick\" x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\">%s</text>", Frame::kW - Frame::kRight - 2, f.Y(y) - 3,
                  label);
    }
    std::string path;
    for (size_t i = 0; i < values.size(); ++i) path += Format("%s%.1f %.1f", i ? "L" : "M", f.X(i), f.Y(values[i]));
    b << "<path class=\"run\" d=\"" << path << "\"/>";
    const size_t label_every = (values.size() + 7) / 8;  // robot names need room
    for (size_t i = 0; i < values.size(); ++i) {
      const std::string robot = c["robots"][i].get<std::string>();
      const auto it = flagged.find(static_cast<int>(i));
      std::string rules;
      if (it != flagged.end())
        for (const std::string& r : it->second) rules += (rules.empty() ? "" : ",") + r;
      b << Format("<circle class=\"%s\" cx=\"%.1f\" cy=\"%.1f\" r=\"%s\"><title>%s: %.6g%s</title></circle>", rules.empty() ? "pt" : "flag",
                  f.X(i), f.Y(values[i]), rules.empty() ? "3.5" : "5", Escape(robot).c_str(), values[i],
                  rules.empty() ? "" : (" (rule " + rules + ")").c_str());
      if (!rules.empty())
        b << Format("<text class=\"flag\" x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">%s</text>", f.X(i), f.Y(values[i]) - 9, rules.c_str());
      if (i % label_every == 0)
        b << Format("<text class=\"tick\" x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">%s</text>", f.X(i), Frame::kH - Frame::kBottom + 18,
                    Escape(robot.size() > 12 ? robot.substr(0, 11) + "…" : robot).c_str());
    }
    b << "</svg></figure>\n";
    if (!c["flags"].empty()) {
      b << "<ul>";
      for (const json& fl : c["flags"]) {
        const int i = fl.value("index", 0);
        b << "<li>" << Escape(c["robots"][i].get<std::string>()) << Format(" (%.6g): ", values[i]) << Escape(Str(fl, "why")) << "</li>";
      }
      b << "</ul>\n";
    }
  }
  return Page("odocal fleet", b.str());
}

}  // namespace odocal::records
