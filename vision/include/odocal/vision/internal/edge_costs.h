// The per-pixel least-squares costs of the edge models, with their
// derivatives in closed form: the exact edge model that places each edge of a
// tag (edge_model_refine.cc), the PSF- and tone-free one that measures the
// robot's tag at rest (model_free_refine.cc) and the edge shift measured in a
// tag's pattern (edge_shift.cc). They are evaluated at every pixel of every
// band for every iteration, most of an aprilgrid frame's time and of a
// session's measurement; Ceres' autodiff carried Jets of 6, 8 and 4 through
// the closed forms (edge_functions.h). edge_costs_test checks them against
// central differences of the residuals. Not part of the public surface (here
// so that tests can check them): names and shapes may change with the models.
#ifndef ODOCAL_VISION_INTERNAL_EDGE_COSTS_H_
#define ODOCAL_VISION_INTERNAL_EDGE_COSTS_H_

#include <vector>

#include <ceres/cost_function.h>
#include <opencv2/core.hpp>

namespace odocal::vision::internal {

// The pixels of the band along one detected edge (corner_geometry.h's
// SampleEdgeBand) that the edge models fit.
struct EdgeBandSamples {
  std::vector<cv::Point2d> undistorted;  // pixel centres, undistorted when a camera is given
  // d undistorted / d pixel at each centre (row-major 2x2); the identity
  // without a camera. A pixel is a unit square in the image, not in the
  // undistorted plane: through a fisheye it is a parallelogram up to twice
  // as wide there, and wider on the outer side of an edge than the inner.
  std::vector<cv::Vec4d> jacobian;
  std::vector<double> value;             // grey level
  // +1 where the dark side is inside (towards the tag's centre), -1 where it
  // is outside (an aprilgrid's corner square beyond the tag's corner, whose
  // edge continues the tag's); empty: all +1.
  std::vector<double> polarity;
  std::vector<double> offset_px;         // signed distance from the edge, outwards positive
  cv::Point2d normal_px;                 // outwards, distorted pixels
  // The detector's edge mapped like the pixels: the line n . q = c with n at
  // angle `start_angle` (outwards), c = `start_offset`.
  double start_angle = 0.0;
  double start_offset = 0.0;
};

// The exact edge model (edge_model_refine.cc has its derivation): pixel i's
// residual a + b * fraction_i - value_i, fraction_i the pixel's mean of the
// blurred step across the line n(theta) . q = c, its dark side grown by the
// edge shift. Parameter blocks: (theta, c, a, b, log blur) and (shift, px).
class EdgeModelCost final : public ceres::CostFunction {
 public:
  explicit EdgeModelCost(const EdgeBandSamples* pixels);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const EdgeBandSamples* pixels_;
};

// The PSF- and tone-free edge model (model_free_refine.cc, edge_quality.h):
// pixel i's residual 255 (linear_i / 255)^(1 / gamma) - value_i, linear_i =
// a + b ((1 - w) F(s1) + w F(s2)) with F the pixel's mean of a blurred step
// of spread s across the line n(theta) . q = c. Parameter blocks: the
// edge's (theta, c, a, b) and the tag's shared (log s1, log s2, w, log gamma).
class ModelFreeCost final : public ceres::CostFunction {
 public:
  explicit ModelFreeCost(const EdgeBandSamples* pixels);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const EdgeBandSamples* pixels_;
};

// One pixel of the edge-shift fit (edge_shift.cc): where it is in u (the
// tag's plane in cells), the blur's scale there, its grey level, and the
// black cells near it with the sides of each that face white.
struct ShiftPixel {
  double qx = 0.0, qy = 0.0;  // undistorted pixel
  double ux = 0.0, uy = 0.0;
  double cells_per_px = 0.0;  // sqrt |det d u / d pixel|
  double value = 0.0;
  // Per black cell: its printed bounds in cells (x0 < x1, y0 < y1, y up) and
  // which of its sides (left, right, bottom, top) face white.
  struct Cell {
    double x0, x1, y0, y1;
    bool wl, wr, wb, wt;
  };
  std::vector<Cell> cells;
};

// The edge shift with u fixed by the refined corners: pixel i's residual
// dark + (light - dark) (1 - black_i) - value_i, black_i the blurred print's
// black fraction with every side that faces white moved out by s cells and
// the whole scaled by lambda = n / (n + 2 s) (the outer edges stay where the
// edge fit put them). One parameter block: (s cells, log blur px, dark,
// light - dark).
class EdgeShiftCost final : public ceres::CostFunction {
 public:
  EdgeShiftCost(const std::vector<ShiftPixel>* pixels, double n);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const std::vector<ShiftPixel>* pixels_;
  double n_;
};

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_INTERNAL_EDGE_COSTS_H_
