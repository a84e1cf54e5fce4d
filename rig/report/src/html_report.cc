#include "odocal/config/files.h"
#include "odocal/base/format.h"
#include "odocal/report/html_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>

#include "odocal/report/json.h"
#include "svg_plot.h"

namespace odocal::report {
namespace {

using nlohmann::json;
using svg::Escape;

constexpr const char* kCw = "#1f77b4";
constexpr const char* kCcw = "#d62728";

std::optional<double> Get(const json& j, const std::string& key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return std::nullopt;
  return j[key].get<double>();
}

std::string WithSigmaHtml(const std::optional<double>& v, const std::optional<double>& sigma, int precision) {
  if (!v) return "&ndash;";
  std::string s = Fixed(*v, precision);
  if (sigma) s += " &plusmn; " + Fixed(*sigma, precision);
  return s;
}

std::string ScalarCell(const json& v) {
  if (v.is_number_float()) return svg::Num(v.get<double>(), 7);
  if (v.is_string()) return Escape(v.get<std::string>());
  if (v.is_null()) return "&ndash;";
  return Escape(v.dump());
}

// A two-column table of an object's scalar members.
std::string KeyValueTable(const json& j) {
  std::string s = "<table class='kv'>";
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!it->is_structured()) s += "<tr><th>" + Escape(it.key()) + "</th><td>" + ScalarCell(*it) + "</td></tr>";
  return s + "</table>\n";
}

struct Point {
  double x, y;
  std::string label;
};

std::vector<Point> UmbmarkPoints(const json& umbmark, const std::string& direction) {
  std::vector<Point> points;
  if (!umbmark.contains("return_errors") || !umbmark["return_errors"].contains(direction))
    return points;
  int k = 0;
  for (const json& e : umbmark["return_errors"][direction]) {
    ++k;
    if (auto x = Get(e, "x_mm"), y = Get(e, "y_mm"); x && y)
      points.push_back({*x, *y, direction + " run " + std::to_string(k)});
  }
  return points;
}

// Borenstein & Feng's figure: each run's return error, the centres of
// gravity (with +-2 sigma bars when runs are repeated) and E_max,syst.
std::string UmbmarkScatter(const json& u, const std::string& title) {
  const std::vector<Point> cw = UmbmarkPoints(u, "cw"), ccw = UmbmarkPoints(u, "ccw");
  const double xcw = Get(u, "x_cg_cw_mm").value_or(0), ycw = Get(u, "y_cg_cw_mm").value_or(0);
  const double xccw = Get(u, "x_cg_ccw_mm").value_or(0), yccw = Get(u, "y_cg_ccw_mm").value_or(0);
  const double emax = Get(u, "emax_syst_mm").value_or(0);
  double r = std::max(emax, 1e-3);
  for (const auto* set : {&cw, &ccw})
    for (const Point& p : *set) r = std::max({r, std::abs(p.x), std::abs(p.y)});
  r *= 1.15;
  svg::Plot plot(640, 460, {-r, r}, {-r, r}, true, false, 190);
  plot.Title(title);
  plot.Axes("x error [mm] (along the start heading)", "y error [mm] (to the left)");
  plot.ZeroLines();
  plot.DataCircle(0, 0, emax, "#777");
  for (const Point& p : cw) plot.Circle(p.x, p.y, 4, kCw, "none", p.label);
  for (const Point& p : ccw) plot.Square(p.x, p.y, 4, kCcw, "none", p.label);
  const json sigma = u.value("sigma_cg", json::object());
  auto bars = [&](double x, double y, const std::optional<double>& sx, const std::optional<double>& sy,
                  const char* colour) {
    if (sx) plot.Line(x - 2 * *sx, y, x + 2 * *sx, y, colour, 1.5);
    if (sy) plot.Line(x, y - 2 * *sy, x, y + 2 * *sy, colour, 1.5);
  };
  bars(xcw, ycw, Get(sigma, "x_cw_mm"), Get(sigma, "y_cw_mm"), kCw);
  bars(xccw, yccw, Get(sigma, "x_ccw_mm"), Get(sigma, "y_ccw_mm"), kCcw);
  plot.Cross(xcw, ycw, 7, kCw);
  plot.Cross(xccw, yccw, 7, kCcw);
  plot.Text(xcw, ycw, "c.g. cw", kCw, 11, "start", 9, -6);
  plot.Text(xccw, yccw, "c.g. ccw", kCcw, 11, "start", 9, -6);
  plot.Legend({{kCw, "cw runs", "circle"},
               {kCcw, "ccw runs", "square"},
               {"#333", "centres of gravity (±2σ)", "cross"},
               {"#777", "E_max,syst = " + Fixed(emax, 2) + " mm", "line"}});
  return plot.Svg("umbmark");
}

std::string UmbmarkTable(const json& u) {
  std::ostringstream os;
  const json sigma = u.value("sigma_cg", json::object());
  os << "<table><tr><th></th><th>x c.g. [mm]</th><th>y c.g. [mm]</th><th>runs</th></tr>";
  os << "<tr><td style='color:" << kCw << "'>cw</td><td>"
     << WithSigmaHtml(Get(u, "x_cg_cw_mm"), Get(sigma, "x_cw_mm"), 3) << "</td><td>"
     << WithSigmaHtml(Get(u, "y_cg_cw_mm"), Get(sigma, "y_cw_mm"), 3) << "</td><td>" << u.value("n_cw", 0)
     << "</td></tr>";
  os << "<tr><td style='color:" << kCcw << "'>ccw</td><td>"
     << WithSigmaHtml(Get(u, "x_cg_ccw_mm"), Get(sigma, "x_ccw_mm"), 3) << "</td><td>"
     << WithSigmaHtml(Get(u, "y_cg_ccw_mm"), Get(sigma, "y_ccw_mm"), 3) << "</td><td>" << u.value("n_ccw", 0)
     << "</td></tr></table>\n";
  os << "<p>E_max,syst <b>" << WithSigmaHtml(Get(u, "emax_syst_mm"), std::nullopt, 3) << " mm</b>; square "
     << WithSigmaHtml(Get(u, "side_mm"), std::nullopt, 0) << " mm, track "
     << WithSigmaHtml(Get(u, "track_mm"), std::nullopt, 1) << " mm.</p>\n";
  if (u.contains("estimate")) {
    const json& e = u["estimate"];
    os << "<table><tr><th>estimate</th><th>value &plusmn; &sigma;</th><th>95 % interval</th></tr>";
    for (const char* k : {"Ed", "Eb"}) {
      os << "<tr><td>" << k << "</td><td>" << WithSigmaHtml(Get(e, k), Get(e, std::string("sigma_") + k), 6)
         << "</td><td>";
      if (e.contains("interval95") && e["interval95"].is_object() && e["interval95"].contains(k))
        os << Fixed(e["interval95"][k][0].get<double>(), 6) << " to "
           << Fixed(e["interval95"][k][1].get<double>(), 6);
      else
        os << "&ndash; (one run a direction: repeat runs for an uncertainty)";
      os << "</td></tr>";
    }
    os << "</table>\n";
    if (u.contains("quality") && u["quality"].contains("uncertainty"))
      os << "<p class='note'>Uncertainty: " << Escape(u["quality"]["uncertainty"].get<std::string>())
         << ".</p>\n";
  }
  return os.str();
}

std::string ConvergencePlot(const json& iterations) {
  std::vector<double> e;
  for (const json& it : iterations)
    if (auto v = Get(it, "emax_syst_mm")) e.push_back(std::max(*v, 1e-4));
  if (e.empty()) return "";
  const double lo = *std::min_element(e.begin(), e.end()), hi = *std::max_element(e.begin(), e.end());
  svg::Plot plot(460, 300, {0.5, e.size() + 0.5},
                 {std::pow(10.0, std::floor(std::log10(lo))), std::pow(10.0, std::ceil(std::log10(hi * 1.01)))},
                 false, true);
  plot.Title("Convergence: E_max,syst per iteration");
  plot.Axes("iteration", "E_max,syst [mm] (log)", true);
  std::vector<std::pair<double, double>> pts;
  for (size_t i = 0; i < e.size(); ++i) pts.push_back({i + 1.0, e[i]});
  plot.Polyline(pts, "#2ca02c", 2);
  for (const auto& [x, y] : pts) {
    plot.Circle(x, y, 5, "#2ca02c", "none", Fixed(y, 3) + " mm");
    plot.Text(x, y, Fixed(y, 3) + " mm", "#333", 11, "start", 8, -6);
  }
  return plot.Svg("convergence");
}

std::string TrajectoryPlot(const json& trajectories) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const json& t : trajectories)
    for (const json& p : t.value("points_mm", json::array())) {
      x0 = std::min(x0, p[0].get<double>()); x1 = std::max(x1, p[0].get<double>());
      y0 = std::min(y0, p[1].get<double>()); y1 = std::max(y1, p[1].get<double>());
    }
  if (x0 > x1) return "";
  const double pad = 0.08 * std::max(x1 - x0, y1 - y0) + 10;
  svg::Plot plot(720, 460, {x0 - pad, x1 + pad}, {y0 - pad, y1 + pad}, true, false, 180);
  plot.Title("Trajectories measured (camera or tracker frame)");
  plot.Axes("x [mm]", "y [mm]");
  const char* palette[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};
  std::vector<std::vector<std::string>> legend;
  int k = 0;
  for (const json& t : trajectories) {
    std::vector<std::pair<double, double>> pts;
    for (const json& p : t.value("points_mm", json::array()))
      pts.push_back({p[0].get<double>(), p[1].get<double>()});
    if (pts.empty()) continue;
    const std::string colour = palette[k++ % 8];
    plot.Polyline(pts, colour, 1.5);
    plot.Circle(pts.front().first, pts.front().second, 4, "none", colour, "start");
    plot.Circle(pts.back().first, pts.back().second, 2.5, colour, "none", "end");
    if (legend.size() < 8) legend.push_back({colour, t.value("name", std::string("run")), "line"});
  }
  plot.Legend(legend);
  return plot.Svg("trajectories");
}

std::string BlandAltmanPlot(const json& a) {
  const std::string unit = a.value("unit", std::string("mm"));
  const std::string axis = a.value("axis", std::string("?"));
  const std::vector<double> m = a.value("means", std::vector<double>{});
  const std::vector<double> d = a.value("differences", std::vector<double>{});
  if (m.empty() || m.size() != d.size()) return "";
  const double bias = *Get(a, "bias"), lo = *Get(a, "lower_limit"), hi = *Get(a, "upper_limit");
  const json lci = a["lower_limit_ci"], uci = a["upper_limit_ci"], bci = a["bias_ci"];
  double ymin = std::min(lci[0].get<double>(), 0.0), ymax = std::max(uci[1].get<double>(), 0.0);
  for (double v : d) { ymin = std::min(ymin, v); ymax = std::max(ymax, v); }
  const double ypad = 0.08 * (ymax - ymin) + 1e-6;
  double xmin = *std::min_element(m.begin(), m.end()), xmax = *std::max_element(m.begin(), m.end());
  const double xpad = 0.08 * (xmax - xmin) + 1.0;
  svg::Plot plot(520, 330, {xmin - xpad, xmax + xpad}, {ymin - ypad, ymax + ypad});
  plot.Title("Bland–Altman, " + axis + ": manual − camera");
  plot.Axes("mean of manual and camera [" + unit + "]", "manual − camera [" + unit + "]");
  plot.HBand(lci[0].get<double>(), lci[1].get<double>(), "#ff7f0e", 0.15);
  plot.HBand(uci[0].get<double>(), uci[1].get<double>(), "#ff7f0e", 0.15);
  plot.HBand(bci[0].get<double>(), bci[1].get<double>(), "#1f77b4", 0.15);
  const auto& xr = plot.x_range();
  plot.Line(xr.lo, 0, xr.hi, 0, "#999", 1);
  plot.Line(xr.lo, bias, xr.hi, bias, "#1f77b4", 2);
  plot.Line(xr.lo, lo, xr.hi, lo, "#ff7f0e", 1.5, "6,4");
  plot.Line(xr.lo, hi, xr.hi, hi, "#ff7f0e", 1.5, "6,4");
  plot.Text(xr.hi, bias, "bias " + Fixed(bias, 2), "#1f77b4", 11, "end", -4, -4);
  plot.Text(xr.hi, hi, "upper " + Fixed(hi, 2), "#b85c00", 11, "end", -4, -4);
  plot.Text(xr.hi, lo, "lower " + Fixed(lo, 2), "#b85c00", 11, "end", -4, 12);
  std::vector<bool> outlier(d.size(), false);
  for (const json& o : a.value("outliers", json::array())) {
    // outliers are listed by run and line; match on the difference value
    for (size_t i = 0; i < d.size(); ++i)
      if (std::abs(d[i] - o["difference"].get<double>()) < 1e-12) outlier[i] = true;
  }
  const std::vector<std::string> runs = a.value("runs", std::vector<std::string>{});
  for (size_t i = 0; i < d.size(); ++i) {
    const std::string tip = (i < runs.size() ? runs[i] + ": " : "") + Fixed(d[i], 3) + " " + unit;
    if (outlier[i]) plot.Square(m[i], d[i], 5, "#d62728", "#000", "outlier " + tip);
    else plot.Circle(m[i], d[i], 3.5, "#333", "none", tip);
  }
  return plot.Svg("bland-altman");
}

std::string BlandAltmanTable(const json& axes) {
  std::ostringstream os;
  os << "<table><tr><th>axis</th><th>n</th><th>bias [CI]</th><th>sd</th><th>lower limit [CI]</th>"
        "<th>upper limit [CI]</th><th>outliers</th><th>camera &sigma; max</th></tr>";
  auto ci = [](const json& c) {
    return "[" + Fixed(c[0].get<double>(), 2) + ", " + Fixed(c[1].get<double>(), 2) + "]";
  };
  for (const json& a : axes) {
    std::string outliers;
    for (const json& o : a.value("outliers", json::array()))
      outliers += Escape(o["run"].get<std::string>()) + " (line " + std::to_string(o["line"].get<int>()) +
                  ", " + Fixed(o["difference"].get<double>(), 2) + ") ";
    const std::string unit = " " + a.value("unit", std::string());
    os << "<tr><td>" << Escape(a.value("axis", std::string())) << "</td><td>" << a.value("n", 0)
       << "</td><td>" << Fixed(a["bias"].get<double>(), 2) << unit << " " << ci(a["bias_ci"])
       << "</td><td>" << Fixed(a["sd"].get<double>(), 2) << "</td><td>"
       << Fixed(a["lower_limit"].get<double>(), 2) << " " << ci(a["lower_limit_ci"]) << "</td><td>"
       << Fixed(a["upper_limit"].get<double>(), 2) << " " << ci(a["upper_limit_ci"]) << "</td><td>"
       << (outliers.empty() ? "none" : outliers) << "</td><td>"
       << Fixed(a.value("camera_sigma_max", 0.0), 3) << "</td></tr>";
  }
  return os.str() + "</table>\n";
}

std::string RunsTable(const json& runs) {
  std::ostringstream os;
  os << "<table><tr><th>run</th><th>procedure</th><th>direction</th><th>x [mm]</th><th>y [mm]</th>"
        "<th>&theta; [deg]</th><th>flags</th></tr>";
  for (const json& r : runs) {
    os << "<tr><td>" << Escape(r.value("name", std::string())) << "</td><td>"
       << Escape(r.value("procedure", std::string())) << "</td><td>"
       << Escape(r.value("direction", std::string())) << "</td>";
    const json e = r.value("return_error", json());
    const json s = r.value("sigma", json());
    for (const char* k : {"x_mm", "y_mm", "theta_deg"})
      os << "<td>" << WithSigmaHtml(Get(e, k), Get(s, k), std::string(k) == "theta_deg" ? 4 : 3) << "</td>";
    std::string flags;
    for (const json& f : r.value("flags", json::array())) flags += (flags.empty() ? "" : ", ") + f.get<std::string>();
    os << "<td" << (flags.empty() ? "" : " class='flag'") << ">" << (flags.empty() ? "ok" : Escape(flags))
       << "</td></tr>";
  }
  return os.str() + "</table>\n";
}

}  // namespace

std::string ReportHtml(const json& report, const std::string& title) {
  std::ostringstream os;
  os << "<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>" << Escape(title)
     << "</title><style>body{font-family:sans-serif;margin:2em;max-width:1150px;color:#222}"
        "td,th{padding:2px 8px;text-align:left;border-bottom:1px solid #eee}table{border-collapse:collapse;margin:0.5em 0}"
        "th{background:#f4f4f4}.flag{color:#b00}.note{color:#555}.verdict{background:#eef6ee;border-left:4px solid #2ca02c;padding:0.6em 1em}"
        "svg{margin:0.4em 0.4em 0.4em 0;vertical-align:top}pre{background:#f6f6f6;padding:1em;font-size:11px;overflow:auto}"
        "</style></head><body>\n";
  os << "<h1>" << Escape(title) << "</h1>\n";
  for (const char* k : {"session", "scenario", "manual", "measurement"})
    if (report.contains(k) && report[k].is_string())
      os << "<div class='note'>" << k << ": " << Escape(report[k].get<std::string>()) << "</div>\n";
  if (report.contains("sessions") && report["sessions"].is_array())
    for (const json& s : report["sessions"])
      if (s.contains("session") && s["session"].is_string()) {
        os << "<div class='note'>session: " << Escape(s["session"].get<std::string>()) << "</div>\n";
        // Where the lengths come from: what Es's uncertainty rests on.
        if (s.contains("camera_scale") && s["camera_scale"].is_object())
          os << "<div class='note'>camera scale: "
             << Escape(s["camera_scale"].value("explanation", std::string())) << "</div>\n";
        if (s.contains("segmented_runs") && s["segmented_runs"].is_array())
          for (const json& a : s["segmented_runs"])
            os << "<div class='note'>found " << Escape(a.value("run", std::string())) << " at "
               << Fixed(a.value("start_s", 0.0), 1) << "-" << Fixed(a.value("end_s", 0.0), 1) << " s: "
               << Escape(a.value("found", std::string())) << "</div>\n";
      }

  if (report.contains("verdict")) {
    const json& v = report["verdict"];
    os << "<h2>Verdict</h2><div class='verdict'><p><b>" << Escape(v.value("text", std::string()))
       << "</b></p><ul>";
    for (const json& s : v.value("axes", json::array())) os << "<li>" << Escape(s.get<std::string>()) << "</li>";
    os << "</ul></div>\n";
  }
  if (report.contains("axes") && report["axes"].is_array() && !report["axes"].empty()) {
    os << "<h2>Agreement: manual against camera (Bland–Altman)</h2>\n<p class='note'>Differences are "
          "manual − camera; lines: bias (blue) and " << svg::Num(100 * report.value("confidence", 0.95), 3)
       << " % limits of agreement (orange, dashed); bands: their confidence intervals; red squares: outliers "
          "(outside the 99.9 % prediction interval of the other readings).</p>\n";
    for (const json& a : report["axes"]) os << BlandAltmanPlot(a);
    os << BlandAltmanTable(report["axes"]);
  }
  if (report.contains("umbmark") && report["umbmark"].is_object()) {
    os << "<h2>UMBMark</h2>\n" << UmbmarkScatter(report["umbmark"], "Return errors (true − odometry)")
       << UmbmarkTable(report["umbmark"]);
  }
  if (report.contains("iterations") && report["iterations"].is_array()) {
    os << "<h2>Iterations</h2>\n" << ConvergencePlot(report["iterations"]);
    if (auto imp = Get(report, "improvement"))
      os << "<p>Improvement (first E_max,syst ÷ last): <b>" << Fixed(*imp, 1) << "×</b></p>\n";
    int k = 0;
    for (const json& it : report["iterations"]) {
      ++k;
      if (!it.contains("umbmark")) continue;
      os << "<div><h3>Iteration " << k << "</h3>"
         << UmbmarkScatter(it["umbmark"], "Iteration " + std::to_string(k) + ": return errors")
         << UmbmarkTable(it["umbmark"]);
      // A round that pushed nothing ("pushed": null in the station's report) says so.
      if (it.contains("pushed"))
        os << (it["pushed"].is_object() && !it["pushed"].empty() ? "<p>Pushed:</p>" + KeyValueTable(it["pushed"])
                                                                 : std::string("<p>Nothing pushed.</p>\n"));
      os << "</div>\n";
    }
  }
  if (report.contains("trajectories") && report["trajectories"].is_array())
    os << "<h2>Trajectories</h2>\n" << TrajectoryPlot(report["trajectories"]);
  if (report.contains("runs") && report["runs"].is_array() && !report["runs"].empty())
    os << "<h2>Runs (camera or pose log)</h2>\n<p class='note'>Return error &plusmn; &sigma;, in the run's start "
          "frame.</p>\n" << RunsTable(report["runs"]);
  if (report.contains("cvra") && report["cvra"].is_object()) {
    os << "<h2>CVRA</h2>\n";
    for (auto it = report["cvra"].begin(); it != report["cvra"].end(); ++it)
      os << "<h3>" << Escape(it.key()) << "</h3>" << KeyValueTable(*it);
  }
  if (report.contains("estimator_choice") && report["estimator_choice"].is_object()) {
    const json& c = report["estimator_choice"];
    os << "<h2>Which estimator the export holds</h2>\n<p><b>" << Escape(c.value("chosen", std::string()))
       << "</b> (" << Escape(c.value("requested", std::string())) << "): " << Escape(c.value("why", std::string()))
       << "</p>\n";
    if (c.value("cross_validated", false)) {
      os << "<table><tr><th>candidate</th><th>held-out final error mean &plusmn; &sigma; [mm]</th><th>max [mm]</th>"
            "<th>minus the lowest, paired run by run [mm]</th><th>travel scale &plusmn; &sigma; between runs</th>"
            "</tr>";
      for (const json& k : c.value("candidates", json::array())) {
        const json& e = k["heldout_final_error_mm"];
        if (!e.is_object()) continue;
        os << "<tr><td>" << Escape(k.value("name", std::string())) << "</td><td>"
           << WithSigmaHtml(Get(e, "mean"), Get(e, "sigma"), 2) << "</td><td>" << Fixed(e.value("max", 0.0), 2)
           << "</td><td>";
        if (k.contains("versus_lowest_mm") && k["versus_lowest_mm"].is_object())
          os << WithSigmaHtml(Get(k["versus_lowest_mm"], "mean"), Get(k["versus_lowest_mm"], "sigma"), 2);
        os << "</td><td>";
        if (k.contains("travel_scale") && k["travel_scale"].is_object())
          os << WithSigmaHtml(Get(k["travel_scale"], "value"), Get(k["travel_scale"], "sigma_between_runs"), 5);
        os << "</td></tr>";
      }
      os << "</table>\n<p>Decided by: " << Escape(c.value("basis", std::string())) << "</p>\n";
    }
  }
  // Each block under a heading in words, its report.json key beside it.
  static constexpr std::pair<const char*, const char*> kBlocks[] = {
      {"corrected", "Corrected parameters"},
      {"robot_params_final", "The robot's parameters at the end"},
      {"ros2", "ROS 2 wheel multipliers"},
      {"truth", "The simulation's truth"},
      {"quality", "Quality"}};
  for (const auto& [key, heading] : kBlocks)
    if (report.contains(key) && report[key].is_object())
      os << "<h2>" << heading << " <small><code>" << key << "</code></small></h2>\n" << KeyValueTable(report[key]);
  if (report.contains("notes") && report["notes"].is_array() && !report["notes"].empty()) {
    os << "<h2>Notes</h2><ul>";
    for (const json& n : report["notes"]) os << "<li>" << ScalarCell(n) << "</li>";
    os << "</ul>\n";
  }
  os << "<details><summary>report.json</summary><pre>" << Escape(report.dump(2)) << "</pre></details>\n";
  os << "</body></html>\n";
  return os.str();
}

Status WriteReportHtml(const json& report, const std::string& title, const std::string& path) {
  return config::WriteFileAtomically(path, ReportHtml(report, title));
}

}  // namespace odocal::report
