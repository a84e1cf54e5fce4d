// Small inline-SVG plotting helpers shared by the HTML reports (report.html,
// explain.html): a plot frame with linear axes, nice ticks and labels, and
// the few marks the reports draw. Output is plain SVG text: no scripts, no
// external assets.
#ifndef ODOCAL_REPORT_SVG_PLOT_H_
#define ODOCAL_REPORT_SVG_PLOT_H_

#include <string>
#include <vector>

namespace odocal::report::svg {

// "<" ">" "&" "'" "\"" escaped for HTML text and attributes.
std::string Escape(const std::string& text);
// About `count` round tick values covering [lo, hi].
std::vector<double> NiceTicks(double lo, double hi, int count = 5);
// A short number for labels: no trailing zeros.
std::string Num(double v, int precision = 3);

class Plot {
 public:
  struct Range {
    double lo = 0.0, hi = 1.0;
  };
  // `equal_aspect`: one unit is as long in x as in y (ranges widened to fit).
  // `legend_px`: room right of the plot for the legend, so it hides no data.
  Plot(double width_px, double height_px, Range x, Range y, bool equal_aspect = false,
       bool log_y = false, double legend_px = 0.0);

  double X(double x) const;
  double Y(double y) const;
  const Range& x_range() const { return x_; }
  const Range& y_range() const { return y_; }

  void Title(const std::string& text);
  void Axes(const std::string& x_label, const std::string& y_label, bool integer_x = false);
  // Lines through the origin (when inside the ranges).
  void ZeroLines();
  void Circle(double x, double y, double r_px, const std::string& fill,
              const std::string& stroke = "none", const std::string& tooltip = "");
  void Square(double x, double y, double half_px, const std::string& fill,
              const std::string& stroke = "none", const std::string& tooltip = "");
  void Cross(double x, double y, double half_px, const std::string& stroke, double width = 2.5);
  void Line(double x1, double y1, double x2, double y2, const std::string& stroke,
            double width = 1.0, const std::string& dash = "");
  void HBand(double y1, double y2, const std::string& fill, double opacity);
  // A filled rectangle between data corners (x1, y1) and (x2, y2): a bar.
  void Rect(double x1, double y1, double x2, double y2, const std::string& fill,
            const std::string& tooltip = "");
  void Polyline(const std::vector<std::pair<double, double>>& points, const std::string& stroke,
                double width = 1.5);
  // A circle of radius `r` in data units (equal-aspect plots).
  void DataCircle(double cx, double cy, double r, const std::string& stroke,
                  const std::string& dash = "4,3");
  void Text(double x, double y, const std::string& text, const std::string& fill = "#333",
            int size = 11, const std::string& anchor = "start", double dx_px = 0.0,
            double dy_px = 0.0);
  // Legend entries at the top-right: {colour, label, marker "circle"|"square"|"line"|"cross"}.
  void Legend(const std::vector<std::vector<std::string>>& entries);
  std::string Svg(const std::string& css_class = "plot") const;

 private:
  double w_, h_;
  double left_ = 62, right_ = 16, top_ = 28, bottom_ = 44;
  double legend_px_ = 0.0;
  Range x_, y_;
  bool log_y_;
  std::string body_;
};

}  // namespace odocal::report::svg

#endif  // ODOCAL_REPORT_SVG_PLOT_H_
