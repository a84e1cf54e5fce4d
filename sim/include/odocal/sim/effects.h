// Hidden physical effects: what the virtual world does that the base model
// (two wheel diameters and a track) does not. A scenario's `effects:` list
// turns them on; estimators never see this struct.
//
// Robot-side effects act in VirtualRobot; camera-side effects act in the
// virtual camera (rendering), which reads them from here too.
// Frames: robot REP-103 (x forward, y left); world REP-103. Units: SI.
#ifndef ODOCAL_SIM_EFFECTS_H_
#define ODOCAL_SIM_EFFECTS_H_

#include <optional>
#include <string>
#include <vector>

namespace odocal::sim {

// {name: tag_offset, x_mm, y_mm}: the tag's centre is not on the wheel-axle
// midpoint; the operator's tag spec says it is where the scenario's tag key says.
struct TagOffsetEffect {
  double x_m = 0.0;
  double y_m = 0.0;
};

// {name: camera_latency, ms}: video timestamps lag the telemetry clock: a
// frame captured at telemetry time t is stamped t - latency.
struct CameraLatencyEffect {
  double latency_s = 0.0;
};

// {name: turn_slip, fraction_at_1rad_s}: in-place turns at omega rad/s achieve
// (1 - fraction_at_1rad_s * |omega|) of the rotation the wheels imply.
struct TurnSlipEffect {
  double fraction_at_1rad_s = 0.0;
};

// {name: lens_distortion, k1}: the lens's true k1 is the calibration file's
// plus this.
struct LensDistortionEffect {
  double k1_delta = 0.0;
};

// {name: encoder_backlash, ticks}: after a wheel reverses, this many encoder
// ticks pass (the motor turns, the encoder counts) before the wheel moves.
struct EncoderBacklashEffect {
  double ticks = 0.0;
};

// {name: carpet_drift, grain_deg, rate_mm_per_m}: while driving, the robot
// drifts to its left by rate * cos(heading - grain) per metre travelled
// forward (largest along the grain, opposite going against it, none across).
struct CarpetDriftEffect {
  double grain_rad = 0.0;
  double rate_m_per_m = 0.0;
};

// {name: tracker_yaw, deg}: the tracked body (the tag) is mounted turned by
// this angle on the robot: the pose source reports the robot's heading plus
// it (and, converting to the robot with the operator's body offset, that
// offset turned by it). Camera-side: the stand-in camera and the renderer.
struct TrackerYawEffect {
  double yaw_rad = 0.0;
};

// {name: speed_slip, fraction_at_1m_s}: each wheel's ground travel is its
// rolled travel times (1 - k |v_wheel| / (1 m/s)): slip that grows with speed.
struct SpeedSlipEffect {
  double fraction_at_1m_s = 0.0;
};

// {name: arc_scale, fraction_at_1_per_m}: on an arc of curvature kappa (1/m)
// each wheel's ground travel is its rolled travel times (1 - c |kappa|): the
// tyres scrub on a curve (their contact patches must yaw as they roll, by
// kappa per metre), and the scrub costs travel in proportion. Acts on arc
// primitives only (a straight has kappa = 0; a turn in place is turn_slip's).
struct ArcScaleEffect {
  double fraction_at_1_per_m = 0.0;
};

// {name: rolling_shutter, ms}: the camera exposes its image rows one after
// another over `readout_s`, top to bottom: row v (of H) at the frame's
// mid-exposure time (its stamp) + (v / (H - 1) - 1/2) readout. Camera-side:
// the pose-level twin of the rendered camera's `rolling_shutter_ms`
// (vision/image_formation.h). The stand-in camera shows a frame whose tag is
// at row fraction f with the pose at capture + (f - 1/2) readout; a rendered
// scenario renders it (it replaces a camera profile's readout, and a scenario
// may not give both it and camera.rolling_shutter_ms).
struct RollingShutterEffect {
  double readout_s = 0.0;
};

// {name: eccentric_wheel, wheel, amplitude, phase_deg}: one wheel's rolling
// radius varies with its angle phi as r (1 + amplitude sin(phi + phase)),
// phi = 2 pi shaft ticks / ticks_per_rev (0 when the robot is made).
// {name: oval_wheel, ...} the same twice a turn, sin(2 phi + phase):
// simulator only, in no candidate's family, so that explain must report it
// as unexplained rather than name the nearest candidate.
struct EccentricWheelEffect {
  bool left = true;  // which wheel
  double amplitude = 0.0;
  double phase_rad = 0.0;
};

struct Effects {
  std::optional<TagOffsetEffect> tag_offset;
  std::optional<CameraLatencyEffect> camera_latency;
  std::optional<TurnSlipEffect> turn_slip;
  std::optional<LensDistortionEffect> lens_distortion;
  std::optional<EncoderBacklashEffect> encoder_backlash;
  std::optional<CarpetDriftEffect> carpet_drift;
  std::optional<TrackerYawEffect> tracker_yaw;
  std::optional<SpeedSlipEffect> speed_slip;
  std::optional<ArcScaleEffect> arc_scale;
  std::optional<RollingShutterEffect> rolling_shutter;
  std::optional<EccentricWheelEffect> eccentric_wheel;
  std::optional<EccentricWheelEffect> oval_wheel;

  // The names of the effects that are on, in the order above.
  std::vector<std::string> Names() const;
  bool empty() const { return Names().empty(); }
};

}  // namespace odocal::sim

#endif  // ODOCAL_SIM_EFFECTS_H_
