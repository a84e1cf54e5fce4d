#include "svg_plot.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "odocal/base/format.h"

namespace odocal::report::svg {

std::string Escape(const std::string& text) { return HtmlEscape(text); }

std::vector<double> NiceTicks(double lo, double hi, int count) {
  std::vector<double> ticks;
  if (!(hi > lo)) return {lo};
  const double raw = (hi - lo) / std::max(1, count);
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  double step = p;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * p >= raw) { step = m * p; break; }
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * step; v += step)
    ticks.push_back(std::abs(v) < 1e-12 * step ? 0.0 : v);
  return ticks;
}

std::string Num(double v, int precision) { return Format("%.*g", precision, v); }

namespace {
std::string F(double v) { return Fixed(v, 1); }
}  // namespace

Plot::Plot(double width_px, double height_px, Range x, Range y, bool equal_aspect, bool log_y,
           double legend_px)
    : w_(width_px), h_(height_px), x_(x), y_(y), log_y_(log_y) {
  right_ += legend_px;
  legend_px_ = legend_px;
  if (!(x_.hi > x_.lo)) { x_.lo -= 1; x_.hi += 1; }
  if (!(y_.hi > y_.lo)) { y_.lo -= 1; y_.hi += 1; }
  if (equal_aspect) {
    const double pw = w_ - left_ - right_, ph = h_ - top_ - bottom_;
    const double scale = std::max((x_.hi - x_.lo) / pw, (y_.hi - y_.lo) / ph);
    const double cx = 0.5 * (x_.lo + x_.hi), cy = 0.5 * (y_.lo + y_.hi);
    x_ = {cx - 0.5 * scale * pw, cx + 0.5 * scale * pw};
    y_ = {cy - 0.5 * scale * ph, cy + 0.5 * scale * ph};
  }
}

double Plot::X(double x) const { return left_ + (w_ - left_ - right_) * (x - x_.lo) / (x_.hi - x_.lo); }

double Plot::Y(double y) const {
  if (log_y_) {
    const double l = std::log10(std::max(y, 1e-300));
    return h_ - bottom_ - (h_ - top_ - bottom_) * (l - std::log10(y_.lo)) /
                              (std::log10(y_.hi) - std::log10(y_.lo));
  }
  return h_ - bottom_ - (h_ - top_ - bottom_) * (y - y_.lo) / (y_.hi - y_.lo);
}

void Plot::Title(const std::string& text) {
  body_ += "<text x='" + F(left_) + "' y='18' font-size='13' font-weight='bold'>" + Escape(text) +
           "</text>\n";
}

void Plot::Axes(const std::string& x_label, const std::string& y_label, bool integer_x) {
  std::ostringstream os;
  const double x0 = left_, x1 = w_ - right_, y0 = top_, y1 = h_ - bottom_;
  os << "<rect x='" << F(x0) << "' y='" << F(y0) << "' width='" << F(x1 - x0) << "' height='"
     << F(y1 - y0) << "' fill='none' stroke='#888'/>\n";
  for (double t : NiceTicks(x_.lo, x_.hi, 6)) {
    if (integer_x && std::abs(t - std::round(t)) > 1e-9) continue;
    os << "<line class='grid' x1='" << F(X(t)) << "' x2='" << F(X(t)) << "' y1='" << F(y0)
       << "' y2='" << F(y1) << "' stroke='#eee'/><text x='" << F(X(t)) << "' y='" << F(y1 + 14)
       << "' font-size='10' text-anchor='middle'>" << Num(t, 4) << "</text>\n";
  }
  std::vector<double> yt;
  if (log_y_) {
    for (double e = std::floor(std::log10(y_.lo)); e <= std::ceil(std::log10(y_.hi)); e += 1.0)
      for (double m : {1.0, 2.0, 5.0}) {
        const double v = m * std::pow(10.0, e);
        if (v >= y_.lo * (1 - 1e-9) && v <= y_.hi * (1 + 1e-9)) yt.push_back(v);
      }
  } else {
    yt = NiceTicks(y_.lo, y_.hi, 6);
  }
  for (double t : yt) {
    os << "<line class='grid' x1='" << F(x0) << "' x2='" << F(x1) << "' y1='" << F(Y(t))
       << "' y2='" << F(Y(t)) << "' stroke='#eee'/><text x='" << F(x0 - 4) << "' y='"
       << F(Y(t) + 3) << "' font-size='10' text-anchor='end'>" << Num(t, 4) << "</text>\n";
  }
  os << "<text x='" << F(0.5 * (x0 + x1)) << "' y='" << F(h_ - 8)
     << "' font-size='11' text-anchor='middle'>" << Escape(x_label) << "</text>\n";
  os << "<text x='12' y='" << F(0.5 * (y0 + y1)) << "' font-size='11' text-anchor='middle' "
     << "transform='rotate(-90 12 " << F(0.5 * (y0 + y1)) << ")'>" << Escape(y_label) << "</text>\n";
  body_ += os.str();
}

void Plot::ZeroLines() {
  if (x_.lo < 0 && x_.hi > 0) Line(0, y_.lo, 0, y_.hi, "#999", 1.0);
  if (!log_y_ && y_.lo < 0 && y_.hi > 0) Line(x_.lo, 0, x_.hi, 0, "#999", 1.0);
}

static std::string Tip(const std::string& tooltip) {
  return tooltip.empty() ? "" : "<title>" + Escape(tooltip) + "</title>";
}

void Plot::Circle(double x, double y, double r_px, const std::string& fill,
                  const std::string& stroke, const std::string& tooltip) {
  body_ += "<circle cx='" + F(X(x)) + "' cy='" + F(Y(y)) + "' r='" + F(r_px) + "' fill='" + fill +
           "' stroke='" + stroke + "'>" + Tip(tooltip) + "</circle>\n";
}

void Plot::Square(double x, double y, double half_px, const std::string& fill,
                  const std::string& stroke, const std::string& tooltip) {
  body_ += "<rect x='" + F(X(x) - half_px) + "' y='" + F(Y(y) - half_px) + "' width='" +
           F(2 * half_px) + "' height='" + F(2 * half_px) + "' fill='" + fill + "' stroke='" +
           stroke + "'>" + Tip(tooltip) + "</rect>\n";
}

void Plot::Cross(double x, double y, double half_px, const std::string& stroke, double width) {
  const double px = X(x), py = Y(y);
  body_ += "<path d='M" + F(px - half_px) + "," + F(py - half_px) + "L" + F(px + half_px) + "," +
           F(py + half_px) + "M" + F(px - half_px) + "," + F(py + half_px) + "L" + F(px + half_px) +
           "," + F(py - half_px) + "' stroke='" + stroke + "' stroke-width='" + F(width) +
           "' fill='none'/>\n";
}

void Plot::Line(double x1, double y1, double x2, double y2, const std::string& stroke, double width,
                const std::string& dash) {
  body_ += "<line x1='" + F(X(x1)) + "' y1='" + F(Y(y1)) + "' x2='" + F(X(x2)) + "' y2='" +
           F(Y(y2)) + "' stroke='" + stroke + "' stroke-width='" + F(width) + "'" +
           (dash.empty() ? "" : " stroke-dasharray='" + dash + "'") + "/>\n";
}

void Plot::HBand(double y1, double y2, const std::string& fill, double opacity) {
  const double a = Y(std::max(y1, y2)), b = Y(std::min(y1, y2));
  body_ += "<rect x='" + F(X(x_.lo)) + "' y='" + F(a) + "' width='" + F(X(x_.hi) - X(x_.lo)) +
           "' height='" + F(b - a) + "' fill='" + fill + "' fill-opacity='" + Num(opacity, 2) +
           "'/>\n";
}

void Plot::Rect(double x1, double y1, double x2, double y2, const std::string& fill,
                const std::string& tooltip) {
  const double l = std::min(X(x1), X(x2)), r = std::max(X(x1), X(x2));
  const double t = std::min(Y(y1), Y(y2)), b = std::max(Y(y1), Y(y2));
  body_ += "<rect x='" + F(l) + "' y='" + F(t) + "' width='" + F(r - l) + "' height='" +
           F(b - t) + "' fill='" + fill + "'>" + Tip(tooltip) + "</rect>\n";
}

void Plot::Polyline(const std::vector<std::pair<double, double>>& points, const std::string& stroke,
                    double width) {
  if (points.empty()) return;
  std::string p;
  for (const auto& [x, y] : points) p += F(X(x)) + "," + F(Y(y)) + " ";
  body_ += "<polyline points='" + p + "' fill='none' stroke='" + stroke + "' stroke-width='" +
           F(width) + "'/>\n";
}

void Plot::DataCircle(double cx, double cy, double r, const std::string& stroke,
                      const std::string& dash) {
  const double rx = std::abs(X(cx + r) - X(cx)), ry = std::abs(Y(cy + r) - Y(cy));
  body_ += "<ellipse cx='" + F(X(cx)) + "' cy='" + F(Y(cy)) + "' rx='" + F(rx) + "' ry='" + F(ry) +
           "' fill='none' stroke='" + stroke + "' stroke-dasharray='" + dash + "'/>\n";
}

void Plot::Text(double x, double y, const std::string& text, const std::string& fill, int size,
                const std::string& anchor, double dx_px, double dy_px) {
  body_ += "<text x='" + F(X(x) + dx_px) + "' y='" + F(Y(y) + dy_px) + "' font-size='" +
           std::to_string(size) + "' fill='" + fill + "' text-anchor='" + anchor + "'>" +
           Escape(text) + "</text>\n";
}

void Plot::Legend(const std::vector<std::vector<std::string>>& entries) {
  double y = top_ + 14;
  const double x = legend_px_ > 0.0 ? w_ - legend_px_ + 4 : w_ - right_ - 190;
  body_ += "<rect x='" + F(x - 6) + "' y='" + F(top_ + 4) + "' width='" +
           F(legend_px_ > 0.0 ? legend_px_ - 8 : 190) + "' height='" +
           F(16.0 * entries.size() + 6) + "' fill='#fff' fill-opacity='0.85' stroke='#ccc'/>\n";
  for (const auto& e : entries) {
    const std::string& colour = e[0];
    const std::string& marker = e.size() > 2 ? e[2] : "circle";
    if (marker == "square")
      body_ += "<rect x='" + F(x) + "' y='" + F(y - 8) + "' width='8' height='8' fill='" + colour + "'/>";
    else if (marker == "line")
      body_ += "<line x1='" + F(x - 2) + "' x2='" + F(x + 10) + "' y1='" + F(y - 4) + "' y2='" +
               F(y - 4) + "' stroke='" + colour + "' stroke-width='2'/>";
    else if (marker == "cross")
      body_ += "<path d='M" + F(x) + "," + F(y - 8) + "L" + F(x + 8) + "," + F(y) + "M" + F(x) +
               "," + F(y) + "L" + F(x + 8) + "," + F(y - 8) + "' stroke='" + colour +
               "' stroke-width='2.5'/>";
    else
      body_ += "<circle cx='" + F(x + 4) + "' cy='" + F(y - 4) + "' r='4' fill='" + colour + "'/>";
    body_ += "<text x='" + F(x + 16) + "' y='" + F(y) + "' font-size='11'>" + Escape(e[1]) +
             "</text>\n";
    y += 16;
  }
}

std::string Plot::Svg(const std::string& css_class) const {
  return "<svg xmlns='http://www.w3.org/2000/svg' class='" + css_class + "' width='" + F(w_) +
         "' height='" + F(h_) + "' viewBox='0 0 " + F(w_) + " " + F(h_) +
         "' style='background:#fff;border:1px solid #ccc'>\n" + body_ + "</svg>\n";
}

}  // namespace odocal::report::svg
