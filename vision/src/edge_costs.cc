// The edge models' costs and their derivatives (edge_costs.h).
#include "odocal/vision/internal/edge_costs.h"

#include <cmath>

#include "odocal/vision/internal/edge_functions.h"

namespace odocal::vision::internal {

EdgeModelCost::EdgeModelCost(const EdgeBandSamples* pixels) : pixels_(pixels) {
  set_num_residuals(static_cast<int>(pixels->value.size()));
  mutable_parameter_block_sizes()->push_back(5);
  mutable_parameter_block_sizes()->push_back(1);
}

// With n = (cos theta, sin theta), J the pixel's d undistorted / d pixel,
// g = |J^T n| (a distance in the undistorted plane over the same in the
// image), s = exp(log blur):
//   u  = (n . q - c - polarity shift g) / (g s)   the centre's distance, in s
//   w1 = |(J^T n)_x| / (g s), w2 = |(J^T n)_y| / (g s)   the pixel's two boxes
//   fraction = [H(u + w1/2 + w2/2) - H(u + w1/2 - w2/2)
//               - H(u - w1/2 + w2/2) + H(u - w1/2 - w2/2)] / (w1 w2)
// (a single box (G(u + w/2) - G(u - w/2)) / w when one width is under 1e-3),
// 1 - fraction where the polarity is -1. H' = G, G' = Phi give d fraction /
// d (u, w1, w2); the chain through u, w1, w2 the rest.
bool EdgeModelCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* p = parameters[0];
  const double shift = parameters[1][0];
  const double nx = std::cos(p[0]), ny = std::sin(p[0]);
  const double s = std::exp(p[4]);
  double* jp = jacobians != nullptr ? jacobians[0] : nullptr;
  double* js = jacobians != nullptr ? jacobians[1] : nullptr;
  for (size_t i = 0; i < pixels_->value.size(); ++i) {
    const cv::Point2d& q = pixels_->undistorted[i];
    const cv::Vec4d& J = pixels_->jacobian[i];
    const double gx = J[0] * nx + J[2] * ny, gy = J[1] * nx + J[3] * ny;
    const double g = std::sqrt(gx * gx + gy * gy);
    const double w1 = std::abs(gx) / (g * s), w2 = std::abs(gy) / (g * s);
    const double polarity = pixels_->polarity.empty() ? 1.0 : pixels_->polarity[i];
    const double u = (nx * q.x + ny * q.y - p[1] - polarity * shift * g) / (g * s);
    double fraction, f_u, f_w1 = 0.0, f_w2 = 0.0;
    if (w2 < 1e-3 || w1 < 1e-3) {
      const bool first = !(w1 < 1e-3);  // the box that is left: w1's, else w2's
      const double w = first ? w1 : w2;
      const Normal hi = NormalAt(u + 0.5 * w), lo = NormalAt(u - 0.5 * w);
      const double g_hi = (u + 0.5 * w) * hi.cdf + hi.pdf, g_lo = (u - 0.5 * w) * lo.cdf + lo.pdf;
      fraction = (g_hi - g_lo) / w;
      f_u = (hi.cdf - lo.cdf) / w;
      const double f_w = 0.5 * (hi.cdf + lo.cdf) / w - fraction / w;
      (first ? f_w1 : f_w2) = f_w;
    } else {
      const double a = 0.5 * w1, b = 0.5 * w2;
      const double z[4] = {u + a + b, u + a - b, u - a + b, u - a - b};
      double H[4], G[4];
      for (int k = 0; k < 4; ++k) {
        const Normal nz = NormalAt(z[k]);
        G[k] = z[k] * nz.cdf + nz.pdf;
        H[k] = 0.5 * ((z[k] * z[k] + 1.0) * nz.cdf + z[k] * nz.pdf);
      }
      const double area = w1 * w2;
      fraction = (H[0] - H[1] - H[2] + H[3]) / area;
      f_u = (G[0] - G[1] - G[2] + G[3]) / area;
      f_w1 = 0.5 * (G[0] - G[1] + G[2] - G[3]) / area - fraction / w1;
      f_w2 = 0.5 * (G[0] + G[1] - G[2] - G[3]) / area - fraction / w2;
    }
    if (polarity < 0) fraction = 1.0 - fraction, f_u = -f_u, f_w1 = -f_w1, f_w2 = -f_w2;
    residuals[i] = p[2] + p[3] * fraction - pixels_->value[i];
    if (jp == nullptr && js == nullptr) continue;
    // d / d theta of n, J^T n, g; then of u, w1, w2.
    const double dgx = -J[0] * ny + J[2] * nx, dgy = -J[1] * ny + J[3] * nx;
    const double dg = (gx * dgx + gy * dgy) / g;
    const double u_theta = ((-ny * q.x + nx * q.y - polarity * shift * dg) / (g * s)) - u * dg / g;
    const double w1_theta = (gx < 0 ? -dgx : dgx) / (g * s) - w1 * dg / g;
    const double w2_theta = (gy < 0 ? -dgy : dgy) / (g * s) - w2 * dg / g;
    if (jp != nullptr) {
      double* row = jp + 5 * i;
      row[0] = p[3] * (f_u * u_theta + f_w1 * w1_theta + f_w2 * w2_theta);
      row[1] = p[3] * f_u * (-1.0 / (g * s));
      row[2] = 1.0;
      row[3] = fraction;
      row[4] = p[3] * -(f_u * u + f_w1 * w1 + f_w2 * w2);  // u, w1, w2 all scale as 1 / s
    }
    if (js != nullptr) js[i] = p[3] * f_u * (-polarity / s);
  }
  return true;
}

EdgeShiftCost::EdgeShiftCost(const std::vector<ShiftPixel>* pixels, double n) : pixels_(pixels), n_(n) {
  set_num_residuals(static_cast<int>(pixels->size()));
  mutable_parameter_block_sizes()->push_back(4);
}

// For a cell side at x = lambda a (a its print position, with s added where
// it faces white), z = (x - u) / sigma:
//   d Phi(z) / d s     = phi(z) (dlambda/ds a + lambda da/ds) / sigma,
//   d Phi(z) / d sigma = -phi(z) z / sigma,
// dlambda/ds = -2 lambda^2 / n, sigma = sqrt(exp(2 log blur) + 1/12) cells_per_px
// (the blur and the pixel's box as variances).
bool EdgeShiftCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* p = parameters[0];
  const double s = p[0];
  const double lambda = n_ / (n_ + 2.0 * s), dlambda = -2.0 * lambda * lambda / n_;
  const double e2 = std::exp(2.0 * p[1]);
  const double root = std::sqrt(e2 + 1.0 / 12.0);  // in px
  const double droot = e2 / root;                  // d root / d log blur
  double* jacobian = jacobians != nullptr ? jacobians[0] : nullptr;
  struct Side {
    double phi, d_s, d_sigma;
  };
  for (size_t i = 0; i < pixels_->size(); ++i) {
    const ShiftPixel& q = (*pixels_)[i];
    const double sigma = root * q.cells_per_px;
    // The side at print position a0, moved by s outwards (`sign`) when it
    // faces white, against u.
    const auto side = [&](double a0, bool grows, double sign, double u) {
      const double a = a0 + (grows ? sign * s : 0.0);
      const double z = (lambda * a - u) / sigma;
      const Normal nz = NormalAt(z);
      return Side{nz.cdf, nz.pdf * (dlambda * a + (grows ? sign * lambda : 0.0)) / sigma, -nz.pdf * z / sigma};
    };
    double black = 0.0, black_s = 0.0, black_sigma = 0.0;
    for (const ShiftPixel::Cell& c : q.cells) {
      const Side x1 = side(c.x1, c.wr, 1.0, q.ux), x0 = side(c.x0, c.wl, -1.0, q.ux);
      const Side y1 = side(c.y1, c.wt, 1.0, q.uy), y0 = side(c.y0, c.wb, -1.0, q.uy);
      const double bx = x1.phi - x0.phi, by = y1.phi - y0.phi;
      black += bx * by;
      black_s += (x1.d_s - x0.d_s) * by + bx * (y1.d_s - y0.d_s);
      black_sigma += (x1.d_sigma - x0.d_sigma) * by + bx * (y1.d_sigma - y0.d_sigma);
    }
    residuals[i] = p[2] + p[3] * (1.0 - black) - q.value;
    if (jacobian != nullptr) {
      double* row = jacobian + 4 * i;
      row[0] = -p[3] * black_s;
      row[1] = -p[3] * black_sigma * droot * q.cells_per_px;
      row[2] = 1.0;
      row[3] = 1.0 - black;
    }
  }
  return true;
}

}  // namespace odocal::vision::internal
