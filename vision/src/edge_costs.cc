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
namespace {

// A pixel's mean of the blurred step, fraction(u, w1, w2) (edge_costs.h's
// EdgeModelCost), with its derivatives by u, w1 and w2. The same arithmetic
// as the autodiff costs these replaced, so the residuals are theirs to the
// last bit.
struct PixelFraction {
  double f, f_u, f_w1, f_w2;
};

PixelFraction FractionOfPixel(double u, double w1, double w2) {
  PixelFraction out{};
  if (w2 < 1e-3 || w1 < 1e-3) {
    const bool first = !(w1 < 1e-3);  // the box that is left: w1's, else w2's
    const double w = first ? w1 : w2;
    const Normal hi = NormalAt(u + 0.5 * w), lo = NormalAt(u - 0.5 * w);
    const double g_hi = (u + 0.5 * w) * hi.cdf + hi.pdf, g_lo = (u - 0.5 * w) * lo.cdf + lo.pdf;
    out.f = (g_hi - g_lo) / w;
    out.f_u = (hi.cdf - lo.cdf) / w;
    (first ? out.f_w1 : out.f_w2) = 0.5 * (hi.cdf + lo.cdf) / w - out.f / w;
    return out;
  }
  const double z[4] = {u + 0.5 * w1 + 0.5 * w2, u + 0.5 * w1 - 0.5 * w2, u - 0.5 * w1 + 0.5 * w2,
                       u - 0.5 * w1 - 0.5 * w2};
  double H[4], G[4];
  for (int k = 0; k < 4; ++k) {
    const Normal nz = NormalAt(z[k]);
    G[k] = z[k] * nz.cdf + nz.pdf;
    H[k] = 0.5 * ((z[k] * z[k] + 1.0) * nz.cdf + z[k] * nz.pdf);
  }
  const double area = w1 * w2;
  out.f = (H[0] - H[1] - H[2] + H[3]) / area;
  out.f_u = (G[0] - G[1] - G[2] + G[3]) / area;
  out.f_w1 = 0.5 * (G[0] - G[1] + G[2] - G[3]) / area - out.f / w1;
  out.f_w2 = 0.5 * (G[0] + G[1] - G[2] - G[3]) / area - out.f / w2;
  return out;
}

// The line's normal n = (cos theta, sin theta) as the image sees it at a
// pixel with J = d undistorted / d pixel: J^T n, its length g, and their
// derivatives by theta.
struct ImageNormal {
  double gx, gy, g;
  double dgx, dgy, dg;
};

ImageNormal NormalInImage(const cv::Vec4d& J, double nx, double ny) {
  ImageNormal m{};
  m.gx = J[0] * nx + J[2] * ny;
  m.gy = J[1] * nx + J[3] * ny;
  m.g = std::sqrt(m.gx * m.gx + m.gy * m.gy);
  m.dgx = -J[0] * ny + J[2] * nx;
  m.dgy = -J[1] * ny + J[3] * nx;
  m.dg = (m.gx * m.dgx + m.gy * m.dgy) / m.g;
  return m;
}

}  // namespace

bool EdgeModelCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* p = parameters[0];
  const double shift = parameters[1][0];
  const double nx = std::cos(p[0]), ny = std::sin(p[0]);
  const double s = std::exp(p[4]);
  double* jp = jacobians != nullptr ? jacobians[0] : nullptr;
  double* js = jacobians != nullptr ? jacobians[1] : nullptr;
  for (size_t i = 0; i < pixels_->value.size(); ++i) {
    const cv::Point2d& q = pixels_->undistorted[i];
    const ImageNormal m = NormalInImage(pixels_->jacobian[i], nx, ny);
    const double gx = m.gx, gy = m.gy, g = m.g;
    const double w1 = std::abs(gx) / (g * s), w2 = std::abs(gy) / (g * s);
    const double polarity = pixels_->polarity.empty() ? 1.0 : pixels_->polarity[i];
    const double u = (nx * q.x + ny * q.y - p[1] - polarity * shift * g) / (g * s);
    PixelFraction f = FractionOfPixel(u, w1, w2);
    if (polarity < 0) f = {1.0 - f.f, -f.f_u, -f.f_w1, -f.f_w2};
    residuals[i] = p[2] + p[3] * f.f - pixels_->value[i];
    if (jp == nullptr && js == nullptr) continue;
    // d / d theta of u, w1, w2.
    const double dgx = m.dgx, dgy = m.dgy, dg = m.dg;
    const double u_theta = ((-ny * q.x + nx * q.y - polarity * shift * dg) / (g * s)) - u * dg / g;
    const double w1_theta = (gx < 0 ? -dgx : dgx) / (g * s) - w1 * dg / g;
    const double w2_theta = (gy < 0 ? -dgy : dgy) / (g * s) - w2 * dg / g;
    if (jp != nullptr) {
      double* row = jp + 5 * i;
      row[0] = p[3] * (f.f_u * u_theta + f.f_w1 * w1_theta + f.f_w2 * w2_theta);
      row[1] = p[3] * f.f_u * (-1.0 / (g * s));
      row[2] = 1.0;
      row[3] = f.f;
      row[4] = p[3] * -(f.f_u * u + f.f_w1 * w1 + f.f_w2 * w2);  // u, w1, w2 all scale as 1 / s
    }
    if (js != nullptr) js[i] = p[3] * f.f_u * (-polarity / s);
  }
  return true;
}

ModelFreeCost::ModelFreeCost(const EdgeBandSamples* pixels) : pixels_(pixels) {
  set_num_residuals(static_cast<int>(pixels->value.size()));
  mutable_parameter_block_sizes()->push_back(4);
  mutable_parameter_block_sizes()->push_back(4);
}

// With d = (n . q - c) / g, m = J^T n / g (the image's distance and unit
// normal), each spread's fraction F_k = fraction(d / s_k, |m_x| / s_k,
// |m_y| / s_k) and linear = a + b ((1 - w) F_1 + w F_2) (held at 1e-3 from
// below, where it has no derivative): residual = 255 (linear / 255)^(1 /
// gamma) - value, d residual / d linear = (residual + value) / (gamma
// linear), d residual / d log gamma = -(residual + value) log(linear / 255)
// / gamma.
bool ModelFreeCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* p = parameters[0];
  const double* shared = parameters[1];
  const double nx = std::cos(p[0]), ny = std::sin(p[0]);
  const double s[2] = {std::exp(shared[0]), std::exp(shared[1])};
  const double w = shared[2];
  const double inv_gamma = std::exp(-shared[3]);
  double* jp = jacobians != nullptr ? jacobians[0] : nullptr;
  double* js = jacobians != nullptr ? jacobians[1] : nullptr;
  for (size_t i = 0; i < pixels_->value.size(); ++i) {
    const cv::Point2d& q = pixels_->undistorted[i];
    const ImageNormal m = NormalInImage(pixels_->jacobian[i], nx, ny);
    const double gx = m.gx, gy = m.gy, g = m.g;
    const double d = (nx * q.x + ny * q.y - p[1]) / g;
    const double mx = gx / g, my = gy / g;
    PixelFraction f[2];
    double u[2], w1[2], w2[2];
    for (int k = 0; k < 2; ++k) {
      u[k] = d / s[k];
      w1[k] = std::abs(mx) / s[k];
      w2[k] = std::abs(my) / s[k];
      f[k] = FractionOfPixel(u[k], w1[k], w2[k]);
    }
    const double spread = (1.0 - w) * f[0].f + w * f[1].f;
    double linear = p[2] + p[3] * spread;
    const bool held = linear < 1e-3;
    if (held) linear = 1e-3;
    const double log_linear = std::log(linear / 255.0);
    const double encoded = 255.0 * std::exp(inv_gamma * log_linear);
    residuals[i] = encoded - pixels_->value[i];
    if (jp == nullptr && js == nullptr) continue;
    const double r_linear = held ? 0.0 : inv_gamma * encoded / linear;
    // d / d theta of d, m_x, m_y.
    const double dgx = m.dgx, dgy = m.dgy, dg = m.dg;
    const double d_theta = (-ny * q.x + nx * q.y) / g - d * dg / g;
    const double mx_theta = dgx / g - mx * dg / g, my_theta = dgy / g - my * dg / g;
    const double weight[2] = {1.0 - w, w};
    double spread_theta = 0.0, spread_c = 0.0, spread_log_s[2];
    for (int k = 0; k < 2; ++k) {
      const double f_d = f[k].f_u / s[k];
      const double f_mx = f[k].f_w1 * (mx < 0 ? -1.0 : 1.0) / s[k];
      const double f_my = f[k].f_w2 * (my < 0 ? -1.0 : 1.0) / s[k];
      spread_theta += weight[k] * (f_d * d_theta + f_mx * mx_theta + f_my * my_theta);
      spread_c += weight[k] * f_d * (-1.0 / g);
      spread_log_s[k] = weight[k] * -(f[k].f_u * u[k] + f[k].f_w1 * w1[k] + f[k].f_w2 * w2[k]);
    }
    if (jp != nullptr) {
      double* row = jp + 4 * i;
      row[0] = r_linear * p[3] * spread_theta;
      row[1] = r_linear * p[3] * spread_c;
      row[2] = r_linear;
      row[3] = r_linear * spread;
    }
    if (js != nullptr) {
      double* row = js + 4 * i;
      row[0] = r_linear * p[3] * spread_log_s[0];
      row[1] = r_linear * p[3] * spread_log_s[1];
      row[2] = r_linear * p[3] * (f[1].f - f[0].f);
      row[3] = -encoded * inv_gamma * log_linear;
    }
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
