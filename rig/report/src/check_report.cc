#include "odocal/report/check_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

#include "odocal/base/format.h"
#include "odocal/base/units.h"
#include "odocal/report/json.h"
#include "svg_plot.h"

namespace odocal::report {
namespace {

using calibration::EffectParams;
using nlohmann::json;
using svg::Escape;

constexpr const char* kMeasured = "#222";
// Sets in this order; the nominal set first, in grey.
constexpr const char* kPalette[] = {"#7f7f7f", "#1f77b4", "#2ca02c", "#d62728",
                                    "#9467bd", "#ff7f0e", "#8c564b", "#17becf"};
// The per-run and summary quantities: key, column heading, digits.
struct Quantity {
  const char* key;
  const char* heading;
  int digits;
};
constexpr Quantity kQuantities[] = {{"final_position_error_mm", "final [mm]", 3},
                                    {"final_heading_error_deg", "heading [deg]", 4},
                                    {"rms_error_mm", "RMS [mm]", 3},
                                    {"final_error_percent", "final / distance [%]", 4}};

std::string Colour(size_t set) { return kPalette[set % 8]; }

bool UsesLens(const config::ReplaySet& set) {
  const auto& v = set.model.effects.values;
  return v[EffectParams::kK1] != 0.0 || v[EffectParams::kTiltX] != 0.0 ||
         v[EffectParams::kTiltY] != 0.0;
}

json Thinned(const std::vector<calibration::Pose2>& poses, int max_points) {
  json points = json::array();
  if (poses.empty()) return points;
  const size_t step = std::max<size_t>(1, (poses.size() + max_points - 1) / std::max(1, max_points));
  for (size_t i = 0; i < poses.size(); i += step)
    points.push_back({poses[i].x() * kMToMm, poses[i].y() * kMToMm});
  if ((poses.size() - 1) % step != 0) points.push_back({poses.back().x() * kMToMm, poses.back().y() * kMToMm});
  return points;
}

json EffectsJson(const config::ReplaySet& set) {
  json j = json::object();
  const EffectParams& fx = set.model.effects;
  for (calibration::Effect e : set.effects) {
    const std::string prefix = std::string(calibration::ToString(e)) + ".";
    if (e == calibration::Effect::kCarpetDrift) {
      j[prefix + "rate_m_per_m"] = fx.drift_rate_m_per_m();
      j[prefix + "grain_rad"] = fx.drift_grain_rad();
      continue;
    }
    const std::vector<int> idx = calibration::EffectParamIndices(e);
    const std::vector<std::string> names = calibration::EffectParamNames(e);
    for (size_t k = 0; k < idx.size(); ++k) j[prefix + names[k]] = fx.values[idx[k]];
  }
  return j;
}

std::string Cell(const json& v, int digits) {
  return v.is_number() ? Fixed(v.get<double>(), digits) : std::string("-");
}

std::vector<std::pair<double, double>> Points(const json& points) {
  std::vector<std::pair<double, double>> out;
  for (const json& p : points) out.push_back({p[0].get<double>(), p[1].get<double>()});
  return out;
}

// Measured against each set's prediction, one run, measurement frame.
std::string TrajectorySvg(const json& run) {
  std::vector<std::pair<double, double>> all = Points(run["measured_mm"]);
  for (const json& r : run["results"])
    if (r.value("ok", false))
      for (const auto& p : Points(r["predicted_mm"])) all.push_back(p);
  if (all.empty()) return "";
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& [x, y] : all) {
    x0 = std::min(x0, x); x1 = std::max(x1, x);
    y0 = std::min(y0, y); y1 = std::max(y1, y);
  }
  const double pad = 0.08 * std::max(x1 - x0, y1 - y0) + 10;
  svg::Plot plot(640, 440, {x0 - pad, x1 + pad}, {y0 - pad, y1 + pad}, true, false, 190);
  plot.Title(run["name"].get<std::string>() + ": measured and replayed");
  plot.Axes("x [mm]", "y [mm]");
  std::vector<std::vector<std::string>> legend = {{kMeasured, "measured (camera)", "line"}};
  const auto measured = Points(run["measured_mm"]);
  plot.Polyline(measured, kMeasured, 2.5);
  if (!measured.empty())
    plot.Circle(measured.back().first, measured.back().second, 4, kMeasured, "none", "measured end");
  for (size_t s = 0; s < run["results"].size(); ++s) {
    const json& r = run["results"][s];
    const std::string name = r["set"].get<std::string>();
    if (!r.value("ok", false)) continue;
    const auto pts = Points(r["predicted_mm"]);
    plot.Polyline(pts, Colour(s), 1.5);
    if (!pts.empty())
      plot.Circle(pts.back().first, pts.back().second, 3.5, Colour(s), "none",
                  name + " end: " + Cell(r["final_position_error_mm"], 3) + " mm off");
    legend.push_back({Colour(s), name, "line"});
  }
  plot.Legend(legend);
  return plot.Svg("trajectory");
}

// Final position error per run, one bar per set; a log scale when the sets
// differ by more than 20x (a calibrated set next to a nominal one).
std::string FinalErrorBars(const json& check) {
  const json& runs = check["runs"];
  const size_t n_sets = check["sets"].size();
  double lo = 1e300, hi = 0.0;
  for (const json& run : runs)
    for (const json& r : run["results"])
      if (r.value("ok", false)) {
        const double v = r["final_position_error_mm"].get<double>();
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
  if (!(hi > 0.0) || runs.empty()) return "";
  const bool log_y = hi / std::max(lo, 1e-6) > 20.0;
  const double y_lo = log_y ? std::pow(10.0, std::floor(std::log10(std::max(lo, 1e-4)))) : 0.0;
  const double y_hi = log_y ? std::pow(10.0, std::ceil(std::log10(hi * 1.2))) : hi * 1.15;
  const double n = static_cast<double>(runs.size());
  svg::Plot plot(std::max(420.0, 120.0 + 70.0 * n * static_cast<double>(n_sets) / 2.0 + 190.0), 320,
                 {-0.5, n - 0.5}, {y_lo, y_hi}, false, log_y, 190);
  plot.Title(std::string("Final position error per run") + (log_y ? " (log scale)" : ""));
  plot.Axes("run", "final position error [mm]", true);
  const double width = 0.8 / static_cast<double>(std::max<size_t>(1, n_sets));
  for (size_t k = 0; k < runs.size(); ++k) {
    const json& run = runs[k];
    plot.Text(double(k), y_hi, run["name"].get<std::string>(), "#333", 10, "middle", 0, 12);
    for (size_t s = 0; s < run["results"].size(); ++s) {
      const json& r = run["results"][s];
      const double x = double(k) - 0.4 + width * (double(s) + 0.5);
      if (!r.value("ok", false)) {
        plot.Text(x, y_lo, "n/a", "#b00", 9, "middle", 0, -4);
        continue;
      }
      const double v = r["final_position_error_mm"].get<double>();
      const std::string tip = r["set"].get<std::string>() + ": " + Fixed(v, 3) + " mm";
      plot.Rect(x - 0.45 * width, y_lo, x + 0.45 * width, std::max(v, y_lo), Colour(s), tip);
      plot.Text(x, std::max(v, y_lo), svg::Num(v, 3), "#333", 9, "middle", 0, -3);
    }
  }
  std::vector<std::vector<std::string>> legend;
  for (size_t s = 0; s < n_sets; ++s)
    legend.push_back({Colour(s), check["sets"][s]["name"].get<std::string>(), "square"});
  plot.Legend(legend);
  return plot.Svg("bars");
}

}  // namespace

int CheckResult::Replayed() const {
  int n = 0;
  for (const auto& per_set : replays)
    for (const calibration::RunReplay& r : per_set) n += r.ok() ? 1 : 0;
  return n;
}

CheckResult RunCheck(const calibration::MeasuredSession& session, const std::vector<config::ReplaySet>& sets,
                     const calibration::ReplayOptions& options) {
  CheckResult result;
  result.sets = sets;
  for (const config::ReplaySet& set : sets) {
    std::vector<calibration::RunReplay> per_run;
    const bool lens = UsesLens(set);
    int left = 1, right = 1;
    for (const calibration::MeasuredRun& run : session.runs) {
      calibration::ReplayOptions o = options;
      o.left_direction0 = left;
      o.right_direction0 = right;
      if (run.telemetry.empty()) {
        calibration::RunReplay r;
        r.message = run.name + ": no telemetry (the session's runs[].telemetry); the replay needs "
                               "the ticks";
        per_run.push_back(r);
      } else if (lens && !session.camera) {
        calibration::RunReplay r;
        r.message = run.name + ": the set has a lens error (lens_distortion) and the camera's "
                               "geometry over the tag plane is unknown";
        per_run.push_back(r);
      } else {
        // Only a lens error needs the camera; without one the pose source's
        // poses are compared as they are.
        per_run.push_back(calibration::ReplayRun(
            run, session.believed, set.model,
            lens ? session.camera : std::optional<calibration::FloorCamera>(), o));
      }
      calibration::LastShaftDirections(run, &left, &right);
    }
    result.replays.push_back(std::move(per_run));
  }
  return result;
}

json CheckJson(const std::string& session_path, const calibration::MeasuredSession& session,
               const CheckResult& result, int max_points) {
  json sets = json::array();
  for (const config::ReplaySet& set : result.sets)
    sets.push_back({{"name", set.name},
                    {"kind", ToString(set.kind)},
                    {"file", set.path.empty() ? json(nullptr) : json(set.path)},
                    {"scales",
                     {{"r_left", set.model.scales.r_left},
                      {"r_right", set.model.scales.r_right},
                      {"Eb", set.model.scales.Eb}}},
                    {"params", WheelParamsJson(set.Equivalent(session.believed))},
                    {"effects", EffectsJson(set)}});
  json runs = json::array();
  json not_replayed = json::array();
  for (size_t k = 0; k < session.runs.size(); ++k) {
    const calibration::MeasuredRun& run = session.runs[k];
    std::vector<calibration::Pose2> measured;
    for (const calibration::CameraRecord& c : run.camera)
      if (c.valid) measured.push_back(c.T_world_robot);
    json results = json::array();
    json distance = nullptr;
    for (size_t s = 0; s < result.sets.size(); ++s) {
      const calibration::RunReplay& r = result.replays[s][k];
      if (!r.ok()) {
        results.push_back({{"set", result.sets[s].name}, {"ok", false}, {"reason", r.message}});
        not_replayed.push_back(
            {{"run", run.name}, {"set", result.sets[s].name}, {"reason", r.message}});
        continue;
      }
      distance = r.distance_m * kMToMm;
      results.push_back({{"set", result.sets[s].name},
                         {"ok", true},
                         {"final_position_error_mm", r.final_position_error_m * kMToMm},
                         {"final_heading_error_deg", r.final_heading_error_rad * kRadToDeg},
                         {"rms_error_mm", r.rms_position_error_m * kMToMm},
                         {"final_error_percent", 100.0 * r.final_error_fraction()},
                         {"frames", r.measured.size()},
                         {"start", PoseJson(r.start)},
                         {"predicted_mm", Thinned(r.predicted, max_points)}});
    }
    runs.push_back({{"name", run.name},
                    {"procedure", calibration::ToString(run.spec.procedure)},
                    {"direction", calibration::ToString(run.spec.direction)},
                    {"flags", calibration::ToStrings(run.flags)},
                    {"distance_mm", distance},
                    {"measured_mm", Thinned(measured, max_points)},
                    {"results", results}});
  }
  json summary = json::array();
  for (size_t s = 0; s < result.sets.size(); ++s) {
    json entry = {{"set", result.sets[s].name}};
    int replayed = 0;
    for (const calibration::RunReplay& r : result.replays[s]) replayed += r.ok() ? 1 : 0;
    entry["runs"] = replayed;
    entry["not_replayed"] = static_cast<int>(result.replays[s].size()) - replayed;
    for (const Quantity& q : kQuantities) {
      double max = 0.0, sum = 0.0;
      for (const json& run : runs) {
        const json& r = run["results"][s];
        if (!r.value("ok", false)) continue;
        const double v = std::abs(r[q.key].get<double>());
        max = std::max(max, v);
        sum += v;
      }
      entry[q.key] = replayed == 0 ? json{{"max", nullptr}, {"mean", nullptr}}
                                   : json{{"max", max}, {"mean", sum / replayed}};
    }
    summary.push_back(entry);
  }
  return {{"session", session_path},
          {"nominal", WheelParamsJson(session.believed)},
          {"sets", sets},
          {"summary", summary},
          {"runs", runs},
          {"not_replayed", not_replayed},
          {"frame", "measurement frame of the camera (REP-103), mm; heading errors are predicted "
                    "- measured; summaries of |heading|"}};
}

std::string CheckTable(const json& check) {
  std::ostringstream os;
  char line[256];
  std::snprintf(line, sizeof(line), "%-24s %-16s %12s %14s %10s %20s\n", "run", "set", "final [mm]",
                "heading [deg]", "RMS [mm]", "final / distance [%]");
  os << line;
  for (const json& run : check["runs"])
    for (const json& r : run["results"]) {
      const std::string name = run["name"].get<std::string>(), set = r["set"].get<std::string>();
      if (!r.value("ok", false)) {
        os << std::string(name) << "  " << set << "  not replayed: "
           << r["reason"].get<std::string>() << "\n";
        continue;
      }
      std::snprintf(line, sizeof(line), "%-24s %-16s %12.3f %14.4f %10.3f %20.4f\n", name.c_str(),
                    set.c_str(), r["final_position_error_mm"].get<double>(),
                    r["final_heading_error_deg"].get<double>(), r["rms_error_mm"].get<double>(),
                    r["final_error_percent"].get<double>());
      os << line;
    }
  os << "\nper set, max / mean over the runs replayed (|heading|):\n";
  std::snprintf(line, sizeof(line), "%-16s %5s %19s %19s %19s %19s\n", "set", "runs", "final [mm]",
                "heading [deg]", "RMS [mm]", "final / dist. [%]");
  os << line;
  for (const json& s : check["summary"]) {
    std::string row;
    std::snprintf(line, sizeof(line), "%-16s %5d", s["set"].get<std::string>().c_str(),
                  s["runs"].get<int>());
    row = line;
    for (const Quantity& q : kQuantities) {
      const json& m = s[q.key];
      std::snprintf(line, sizeof(line), " %19s",
                    (Cell(m["max"], q.digits) + " / " + Cell(m["mean"], q.digits)).c_str());
      row += line;
    }
    os << row << "\n";
  }
  return os.str();
}

std::string CheckHtml(const json& check) {
  std::ostringstream os;
  os << "<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>odocal check</title>"
        "<style>body{font-family:sans-serif;margin:2em;max-width:1150px;color:#222}"
        "td,th{padding:2px 8px;text-align:left;border-bottom:1px solid #eee}"
        "table{border-collapse:collapse;margin:0.5em 0}th{background:#f4f4f4}.flag{color:#b00}"
        ".note{color:#555}svg{margin:0.4em 0.4em 0.4em 0;vertical-align:top}"
        "pre{background:#f6f6f6;padding:1em;font-size:11px;overflow:auto}"
        "</style></head><body>\n";
  os << "<h1>Does the calibration hold? Replayed runs against the camera</h1>\n";
  os << "<div class='note'>session: " << Escape(check.value("session", std::string())) << "</div>\n";
  os << "<p class='note'>Each run's ticks replayed through each parameter set from the start pose "
        "the camera saw at rest, compared with every later frame. Final error: predicted − "
        "measured end pose; percentages of the distance the wheels travelled.</p>\n";

  os << "<h2>Parameter sets</h2><table><tr><th>set</th><th>kind</th><th>file</th>"
        "<th>left &empty; [mm]</th><th>right &empty; [mm]</th><th>track [mm]</th>"
        "<th>ticks/rev</th><th>effects</th></tr>";
  for (size_t s = 0; s < check["sets"].size(); ++s) {
    const json& set = check["sets"][s];
    const json& p = set["params"];
    std::string effects;
    for (auto it = set["effects"].begin(); it != set["effects"].end(); ++it)
      effects += (effects.empty() ? "" : ", ") + it.key() + " " + svg::Num(it->get<double>(), 4);
    os << "<tr><td style='color:" << Colour(s) << "'><b>" << Escape(set["name"].get<std::string>())
       << "</b></td><td>" << Escape(set["kind"].get<std::string>()) << "</td><td>"
       << (set["file"].is_string() ? Escape(set["file"].get<std::string>()) : "(session)")
       << "</td><td>" << Fixed(p["left_wheel_diameter_mm"].get<double>(), 4) << "</td><td>"
       << Fixed(p["right_wheel_diameter_mm"].get<double>(), 4) << "</td><td>"
       << Fixed(p["track_mm"].get<double>(), 3) << "</td><td>" << p["ticks_per_rev"].dump()
       << "</td><td>" << (effects.empty() ? "none" : Escape(effects)) << "</td></tr>";
  }
  os << "</table>\n";

  os << "<h2>Summary (max / mean over the runs replayed)</h2><table><tr><th>set</th><th>runs</th>";
  for (const Quantity& q : kQuantities) os << "<th>" << q.heading << "</th>";
  os << "</tr>";
  for (size_t s = 0; s < check["summary"].size(); ++s) {
    const json& e = check["summary"][s];
    os << "<tr><td style='color:" << Colour(s) << "'><b>" << Escape(e["set"].get<std::string>())
       << "</b></td><td" << (e["not_replayed"].get<int>() > 0 ? " class='flag'" : "") << ">"
       << e["runs"].get<int>() << (e["not_replayed"].get<int>() > 0
                                       ? " (" + std::to_string(e["not_replayed"].get<int>()) +
                                             " not replayed)"
                                       : "")
       << "</td>";
    for (const Quantity& q : kQuantities)
      os << "<td>" << Cell(e[q.key]["max"], q.digits) << " / " << Cell(e[q.key]["mean"], q.digits)
         << "</td>";
    os << "</tr>";
  }
  os << "</table>\n" << FinalErrorBars(check);

  os << "<h2>Runs</h2>\n";
  for (const json& run : check["runs"]) {
    os << "<div><h3>" << Escape(run["name"].get<std::string>()) << "</h3><p class='note'>"
       << Escape(run["procedure"].get<std::string>()) << " "
       << Escape(run["direction"].get<std::string>());
    if (run["distance_mm"].is_number())
      os << ", " << Fixed(run["distance_mm"].get<double>(), 0) << " mm of wheel travel";
    std::string flags;
    for (const json& f : run["flags"]) flags += (flags.empty() ? "" : ", ") + f.get<std::string>();
    if (!flags.empty()) os << " <span class='flag'>flags: " << Escape(flags) << "</span>";
    os << "</p>\n" << TrajectorySvg(run);
    os << "<table><tr><th>set</th>";
    for (const Quantity& q : kQuantities) os << "<th>" << q.heading << "</th>";
    os << "</tr>";
    for (size_t s = 0; s < run["results"].size(); ++s) {
      const json& r = run["results"][s];
      os << "<tr><td style='color:" << Colour(s) << "'><b>" << Escape(r["set"].get<std::string>())
         << "</b></td>";
      if (!r.value("ok", false)) {
        os << "<td class='flag' colspan='4'>not replayed: " << Escape(r["reason"].get<std::string>())
           << "</td></tr>";
        continue;
      }
      for (const Quantity& q : kQuantities) os << "<td>" << Cell(r[q.key], q.digits) << "</td>";
      os << "</tr>";
    }
    os << "</table></div>\n";
  }
  os << "<details><summary>check.json</summary><pre>" << Escape(check.dump(2))
     << "</pre></details>\n";
  os << "</body></html>\n";
  return os.str();
}

}  // namespace odocal::report
