// The camera over the tag plane, as far as the lens candidate of `explain`
// needs it: where a tag-plane point is measured when the lens's true k1
// differs from its calibration.
//
// The camera pipeline projects a point through the true lens, undistorts the
// pixel with the calibrated lens and intersects the ray with the tag plane.
// With the true k1 = calibrated k1 + dk1 the measured point moves; this is
// that map, exactly (Newton's method on the calibrated distortion, started
// from the true normalised point, which is within dk1 r^3 of the answer), in
// the camera's real geometry (tilt included) rather than a radial warp on
// the floor. The camera pose is the one the pipeline estimated from the same
// (distorted) views, so it has absorbed part of the k1 error: its scale (the
// trajectory fit sees that as Es) and its tilt (a nuisance of the model).
//
// Pure math, templated for Ceres' automatic differentiation.
// Frames: measurement frame (the tag plane, REP-103, z up); camera frame
// OpenCV's (z along the optical axis, x right, y down). Units: SI.
#ifndef ODOCAL_CALIBRATION_FLOOR_CAMERA_H_
#define ODOCAL_CALIBRATION_FLOOR_CAMERA_H_

#include <array>
#include <cmath>
#include <type_traits>

#include <Eigen/Core>
#include <ceres/rotation.h>

namespace odocal::calibration {

struct FloorCamera {
  // Centre of projection in the measurement frame; z: height above the tag plane.
  Eigen::Vector3d centre_m = Eigen::Vector3d(0.0, 0.0, 1.0);
  // Rotation taking measurement-frame vectors into the camera frame.
  Eigen::Matrix3d R_camera_world = LookingDown();
  // The lens as calibrated: OpenCV's (k1, k2, p1, p2, k3) on normalised coordinates.
  std::array<double, 5> distortion{};

  // A camera at `height_m` over `below_m`, optical axis straight down,
  // image x along the measurement frame's x, without distortion.
  static FloorCamera Overhead(const Eigen::Vector2d& below_m, double height_m) {
    FloorCamera c;
    c.centre_m = Eigen::Vector3d(below_m.x(), below_m.y(), height_m);
    return c;
  }
  static Eigen::Matrix3d LookingDown() {
    Eigen::Matrix3d r;
    r << 1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0;
    return r;
  }
  // Where the optical axis meets the tag plane.
  Eigen::Vector2d AxisPoint() const {
    const Eigen::Vector3d axis = R_camera_world.transpose().col(2);
    const double s = -centre_m.z() / axis.z();
    return (centre_m + s * axis).head<2>();
  }
  bool IsValid() const {
    return centre_m.z() > 0.0 && (R_camera_world.transpose().col(2)).z() < 0.0;
  }
};

namespace floor_camera_internal {

// OpenCV's distortion of a normalised point (x, y) with (k1, k2, p1, p2, k3),
// and its Jacobian.
template <typename T, typename K>
void Distort(const std::array<K, 5>& d, const T& x, const T& y, T* xd, T* yd, T jac[4]) {
  const T r2 = x * x + y * y;
  const T radial = 1.0 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
  const T dradial = d[0] + r2 * (2.0 * d[1] + 3.0 * d[4] * r2);  // d radial / d r2
  *xd = x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x);
  *yd = y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y;
  jac[0] = radial + 2.0 * x * x * dradial + 2.0 * d[2] * y + 6.0 * d[3] * x;  // dxd/dx
  jac[1] = 2.0 * x * y * dradial + 2.0 * d[2] * x + 2.0 * d[3] * y;           // dxd/dy
  jac[2] = 2.0 * x * y * dradial + 2.0 * d[2] * x + 2.0 * d[3] * y;           // dyd/dx
  jac[3] = radial + 2.0 * y * y * dradial + 6.0 * d[2] * y + 2.0 * d[3] * x;  // dyd/dy
}

// Exactly zero, derivatives included when T is a ceres::Jet: a constant 0,
// not a parameter that happens to be at 0.
template <typename T>
bool IsConstantZero(const T& value) {
  if constexpr (std::is_arithmetic_v<T>) {
    return value == 0.0;
  } else {
    return value.a == 0.0 && (value.v.array() == 0.0).all();
  }
}

}  // namespace floor_camera_internal

// The tag-plane point the camera pipeline measures for the true point
// (x, y) when the lens's true k1 is the calibrated one plus `dk1` and the
// camera is really turned by the small angles (tilt_x, tilt_y) about its own
// x and y axes from the pose the pipeline uses. The tilt is what the
// pipeline's plane estimate absorbs of a k1 error (it fits the camera's tilt
// to the same distorted views); the lens candidate fits it as a nuisance.
template <typename T>
void SeenThroughLens(const FloorCamera& camera, const T& x, const T& y, const T& dk1,
                     const T& tilt_x, const T& tilt_y, T* mx, T* my) {
  using floor_camera_internal::Distort;
  const Eigen::Matrix3d& R = camera.R_camera_world;
  const Eigen::Vector3d& C = camera.centre_m;
  const T dx = x - C.x(), dy = y - C.y();
  const double dz = -C.z();
  const T assumed[3] = {R(0, 0) * dx + R(0, 1) * dy + R(0, 2) * dz,
                        R(1, 0) * dx + R(1, 1) * dy + R(1, 2) * dz,
                        R(2, 0) * dx + R(2, 1) * dy + R(2, 2) * dz};
  T uu, vu;
  using floor_camera_internal::IsConstantZero;
  if (IsConstantZero(dk1) && IsConstantZero(tilt_x) && IsConstantZero(tilt_y)) {
    // The lens as calibrated and the camera where the pipeline has it (the
    // trajectory fit without the lens candidate, and its Jets): a rotation by
    // zero adds only zeros, the true lens distorts as the calibrated one
    // does, so Newton starts at its answer with residuals of exactly 0 and
    // steps of exactly 0. Skipped, the result is the same to the bit (but for
    // the sign of a zero); in a fit without the lens they took 45 % of its time.
    uu = assumed[0] / assumed[2];
    vu = assumed[1] / assumed[2];
  } else {
    const T angle_axis[3] = {tilt_x, tilt_y, T(0.0)};
    T real[3];
    ceres::AngleAxisRotatePoint(angle_axis, assumed, real);
    const T u = real[0] / real[2], v = real[1] / real[2];
    // The true lens: the calibrated one with k1 + dk1.
    std::array<T, 5> truth;
    for (int i = 0; i < 5; ++i) truth[i] = T(camera.distortion[i]);
    truth[0] += dk1;
    T ud, vd, jac[4];
    Distort(truth, u, v, &ud, &vd, jac);
    // Undistort with the calibrated lens: Newton from (u, v).
    uu = u;
    vu = v;
    for (int it = 0; it < 3; ++it) {
      T fu, fv;
      Distort(camera.distortion, uu, vu, &fu, &fv, jac);
      const T ru = fu - ud, rv = fv - vd;
      const T det = jac[0] * jac[3] - jac[1] * jac[2];
      uu -= (jac[3] * ru - jac[1] * rv) / det;
      vu -= (-jac[2] * ru + jac[0] * rv) / det;
    }
  }
  // Back onto the plane along the ray (uu, vu, 1) of the assumed camera.
  const T wx = R(0, 0) * uu + R(1, 0) * vu + R(2, 0);
  const T wy = R(0, 1) * uu + R(1, 1) * vu + R(2, 1);
  const T wz = R(0, 2) * uu + R(1, 2) * vu + R(2, 2);
  const T s = dz / wz;
  *mx = C.x() + s * wx;
  *my = C.y() + s * wy;
}

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_FLOOR_CAMERA_H_
