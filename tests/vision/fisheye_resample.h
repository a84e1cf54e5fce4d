// A real photograph as an equidistant (Kannala-Brandt) camera at the same
// place would have taken it: the instrument of "real photographs through a
// fisheye" (docs/vision.md), shared by kalibr_tag_test and
// bench/real_photographs/fisheye_warp.cc (header-only: the bench does not need
// the tests built).
//
// Each pixel of the fisheye image looks along its ray (r = f (theta + k1
// theta^3), centre at the image's middle, OpenCV's pixel convention) to where
// the source camera (K, D: radtan, calibrated from the photographs) saw that
// ray. A world point is then where the fisheye camera would image it, up to
// the source calibration's own error. The image is formed at 2 x 2
// supersampling and averaged (no aliasing where it shrinks the source);
// outside the source's view it is black, as outside a fisheye's image circle.
// `vignette` V darkens it towards the source's corners by up to 1 - V
// ((theta / theta_corner)^4), re-quantised to 8 bits. `rotation` (a Rodrigues
// vector) turns the fisheye camera away from the source's axis: a ray r in the
// fisheye camera's frame is R r in the source's. Turned by 40-60 degrees, what
// the source saw lands towards the fisheye image's rim, where its edges bend most.
#ifndef ODOCAL_TESTS_VISION_FISHEYE_RESAMPLE_H_
#define ODOCAL_TESTS_VISION_FISHEYE_RESAMPLE_H_

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace odocal::testing {

class FisheyeResample {
 public:
  FisheyeResample(cv::Mat K, cv::Mat D, cv::Size source_size, double focal_px, int size_px, double k1 = 0.0,
                  double vignette = 0.0, cv::Vec3d rotation = {0, 0, 0})
      : K_(std::move(K)), D_(std::move(D)), focal_(focal_px), k1_(k1), size_(size_px), centre_((size_px - 1) / 2.0) {
    cv::Rodrigues(rotation, R_);
    const int n = size_ * kSub;
    map_x_.create(n, n, CV_32F);
    map_y_.create(n, n, CV_32F);
    gain_.create(n, n, CV_32F);
    std::vector<cv::Point3f> rays;
    rays.reserve(static_cast<size_t>(n) * n);
    for (int v = 0; v < n; ++v) {
      for (int u = 0; u < n; ++u) {
        const double x = (u + 0.5) / kSub - 0.5 - centre_, y = (v + 0.5) / kSub - 0.5 - centre_;
        const double r = std::hypot(x, y);
        const double theta = Undistort(r / focal_);
        const double s = r > 0 ? std::sin(theta) / r : 1.0 / focal_;
        const cv::Vec3d ray = R_ * cv::Vec3d(x * s, y * s, std::cos(theta));
        if (theta >= M_PI || ray[2] <= std::cos(1.4)) {  // ~80 degrees: far outside any rectilinear source's view
          rays.emplace_back(0.f, 0.f, -1.f);
          continue;
        }
        rays.emplace_back(static_cast<float>(ray[0]), static_cast<float>(ray[1]), static_cast<float>(ray[2]));
      }
    }
    std::vector<cv::Point2f> src;
    cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K_, D_, src);
    const float w = static_cast<float>(source_size.width - 1), h = static_cast<float>(source_size.height - 1);
    std::vector<cv::Point2f> corners{{0, 0}, {w, 0}, {0, h}, {w, h}}, normal;
    cv::undistortPoints(corners, normal, K_, D_);
    for (const auto& p : normal)
      corner_theta_ =
          std::max(corner_theta_, std::atan(std::hypot(static_cast<double>(p.x), static_cast<double>(p.y))));
    for (int v = 0, i = 0; v < n; ++v) {
      for (int u = 0; u < n; ++u, ++i) {
        const bool behind = rays[i].z <= 0.f;
        map_x_.at<float>(v, u) = behind ? -1e4f : src[i].x;
        map_y_.at<float>(v, u) = behind ? -1e4f : src[i].y;
        const double t = std::min(1.0, std::acos(std::min(1.0, static_cast<double>(rays[i].z))) / corner_theta_);
        gain_.at<float>(v, u) = static_cast<float>(1.0 - vignette * std::pow(t, 4));
      }
    }
  }

  // The fisheye image of an 8-bit grey photograph.
  cv::Mat Image(const cv::Mat& grey) const {
    cv::Mat f32, warped, small, out;
    grey.convertTo(f32, CV_32F);
    cv::remap(f32, warped, map_x_, map_y_, cv::INTER_CUBIC, cv::BORDER_CONSTANT, cv::Scalar(0));
    warped = warped.mul(gain_);
    cv::resize(warped, small, cv::Size(size_, size_), 0, 0, cv::INTER_AREA);
    small.convertTo(out, CV_8U);  // rounded, saturated
    return out;
  }

  // Source pixels (a peer's corners) in the fisheye image.
  std::vector<cv::Point2d> Points(const std::vector<cv::Point2d>& source_px) const {
    std::vector<cv::Point2d> out;
    if (source_px.empty()) return out;
    std::vector<cv::Point2d> normal;
    cv::undistortPoints(source_px, normal, K_, D_, cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
    for (const auto& q : normal) {
      const cv::Vec3d ray = R_.t() * cv::Vec3d(q.x, q.y, 1.0);  // the fisheye camera's frame
      const double rn = std::hypot(ray[0], ray[1]);
      const double r = focal_ * Distort(std::atan2(rn, ray[2]));
      out.emplace_back(centre_ + (rn > 0 ? ray[0] / rn * r : 0.0), centre_ + (rn > 0 ? ray[1] / rn * r : 0.0));
    }
    return out;
  }

  double focal_px() const { return focal_; }
  double centre_px() const { return centre_; }
  double k1() const { return k1_; }
  int size_px() const { return size_; }
  double source_corner_theta_rad() const { return corner_theta_; }

 private:
  static constexpr int kSub = 2;
  double Distort(double theta) const { return theta + k1_ * theta * theta * theta; }
  double Undistort(double theta_d) const {
    double t = theta_d;
    for (int i = 0; i < 20; ++i) t -= (Distort(t) - theta_d) / (1.0 + 3.0 * k1_ * t * t);
    return t;
  }

  cv::Mat K_, D_;
  cv::Matx33d R_;
  double focal_, k1_;
  int size_;
  double centre_;
  double corner_theta_ = 0.0;
  cv::Mat map_x_, map_y_, gain_;
};

}  // namespace odocal::testing

#endif  // ODOCAL_TESTS_VISION_FISHEYE_RESAMPLE_H_
