#include <cmath>
#include <filesystem>
#include <functional>
#include <set>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "file_result.h"
#include "odocal/base/units.h"
#include "odocal/config/scenario.h"
#include "yaml_util.h"

namespace odocal::config {
namespace {

using namespace yaml_util;
sim::RobotConfig ParseRobot(const YAML::Node& node) {
  const std::string path = "robot";
  CheckKeys(node, path,
            {"nominal", "true", "start_pose", "speed_mm_s", "turn_rate_deg_s", "accel_mm_s2",
             "turn_accel_deg_s2", "noise", "control_rate_hz", "telemetry_rate_hz", "rest_s",
             "pause_s"});
  sim::RobotConfig c;
  if (!node["nominal"]) Fail(node, "robot.nominal", "missing (required)");
  if (!node["true"]) Fail(node, "robot.true", "missing (required)");
  c.nominal = ParseWheels(node["nominal"], "robot.nominal", true, 0);
  c.truth = ParseWheels(node["true"], "robot.true", false, c.nominal.ticks_per_rev);
  if (const YAML::Node pose = node["start_pose"]) {
    CheckKeys(pose, "robot.start_pose", {"x_mm", "y_mm", "heading_deg"});
    c.start_pose = calibration::Pose2::FromXYHeading(
        OptionalNumber(pose, "robot.start_pose", "x_mm", 0.0) * kMmToM,
        OptionalNumber(pose, "robot.start_pose", "y_mm", 0.0) * kMmToM,
        OptionalNumber(pose, "robot.start_pose", "heading_deg", 0.0) * kDegToRad);
  }
  auto positive = [&](const char* key, double fallback) {
    const double v = OptionalNumber(node, path, key, fallback);
    return Positive(v, node[key] ? node[key] : node, Join(path, key));
  };
  c.limits.speed_m_s = positive("speed_mm_s", 250.0) * kMmToM;
  c.limits.turn_rate_rad_s = positive("turn_rate_deg_s", 60.0) * kDegToRad;
  c.limits.accel_m_s2 = positive("accel_mm_s2", 500.0) * kMmToM;
  c.limits.turn_accel_rad_s2 = positive("turn_accel_deg_s2", 120.0) * kDegToRad;
  c.control_rate_hz = positive("control_rate_hz", 1000.0);
  c.telemetry_rate_hz = positive("telemetry_rate_hz", 50.0);
  if (c.telemetry_rate_hz > c.control_rate_hz)
    Fail(node, "robot.telemetry_rate_hz", "must not exceed robot.control_rate_hz");
  c.rest_s = OptionalNumber(node, path, "rest_s", 1.0);
  if (c.rest_s < 0.0) Fail(node["rest_s"], "robot.rest_s", "must not be negative");
  c.pause_s = OptionalNumber(node, path, "pause_s", 0.3);
  if (c.pause_s < 0.0) Fail(node["pause_s"], "robot.pause_s", "must not be negative");
  // Realistic defaults: a little wheel noise, encoders at an arbitrary phase.
  c.noise.wheel_sigma_m_per_sqrt_m = 0.05e-3;
  c.noise.random_encoder_phase = true;
  if (const YAML::Node noise = node["noise"]) {
    CheckKeys(noise, "robot.noise", {"wheel_mm_per_sqrt_m", "random_encoder_phase"});
    c.noise.wheel_sigma_m_per_sqrt_m =
        OptionalNumber(noise, "robot.noise", "wheel_mm_per_sqrt_m", 0.05) * kMmToM;
    if (c.noise.wheel_sigma_m_per_sqrt_m < 0.0)
      Fail(noise["wheel_mm_per_sqrt_m"], "robot.noise.wheel_mm_per_sqrt_m", "must not be negative");
    if (noise["random_encoder_phase"])
      c.noise.random_encoder_phase =
          Bool(noise["random_encoder_phase"], "robot.noise.random_encoder_phase");
  }
  return c;
}

// camera: its image size, focal lengths, principal point and lens.
void ParseCameraLens(const YAML::Node& node, CameraScenario* c) {
  const std::string path = "camera";
  auto whole = [&](const char* key) {
    if (!node[key]) Fail(node, Join(path, key), "missing (required)");
    const long long v = Integer(node[key], Join(path, key));
    if (v <= 0 || v > 20000) Fail(node[key], Join(path, key), "must be a positive pixel count");
    return static_cast<int>(v);
  };
  c->intrinsics.width = whole("width");
  c->intrinsics.height = whole("height");
  c->intrinsics.fx = Positive(RequiredNumber(node, path, "fx"), node["fx"], "camera.fx");
  c->intrinsics.fy = Positive(RequiredNumber(node, path, "fy"), node["fy"], "camera.fy");
  c->intrinsics.cx = RequiredNumber(node, path, "cx");
  c->intrinsics.cy = RequiredNumber(node, path, "cy");
  if (const YAML::Node m = node["distortion_model"]) {
    const auto lens = vision::ParseLensModel(m.IsScalar() ? m.Scalar() : "");
    if (!lens) Fail(m, "camera.distortion_model", "expected plumb_bob or equidistant");
    c->intrinsics.lens = *lens;
  }
  const bool equidistant = c->intrinsics.lens == vision::LensModel::kEquidistant;
  if (const YAML::Node d = node["distortion"]) {
    if (equidistant && (!d.IsSequence() || d.size() != 4))
      Fail(d, "camera.distortion", "expected a list of 4 numbers [k1, k2, k3, k4] (equidistant)");
    if (!d.IsSequence() || d.size() < 4 || d.size() > 5)
      Fail(d, "camera.distortion", "expected a list of 4 or 5 numbers [k1, k2, p1, p2, k3]");
    for (size_t i = 0; i < d.size(); ++i)
      c->intrinsics.distortion[i] = Number(d[i], "camera.distortion[" + std::to_string(i) + "]");
  }
  std::string why;
  if (!c->intrinsics.IsValid(&why)) Fail(node, path, why);
}

// camera.pose: where the camera hangs and how it is turned.
void ParseCameraPose(const YAML::Node& node, CameraScenario* c) {
  if (!node["pose"]) Fail(node, "camera.pose", "missing (required)");
  const YAML::Node pose = node["pose"];
  CheckKeys(pose, "camera.pose", {"x_mm", "y_mm", "height_mm", "roll_deg", "pitch_deg", "yaw_deg"});
  c->mount.x_mm = OptionalNumber(pose, "camera.pose", "x_mm", 0.0);
  c->mount.y_mm = OptionalNumber(pose, "camera.pose", "y_mm", 0.0);
  c->mount.height_mm =
      Positive(RequiredNumber(pose, "camera.pose", "height_mm"), pose["height_mm"], "camera.pose.height_mm");
  c->mount.roll_deg = OptionalNumber(pose, "camera.pose", "roll_deg", 0.0);
  c->mount.pitch_deg = OptionalNumber(pose, "camera.pose", "pitch_deg", 0.0);
  c->mount.yaw_deg = OptionalNumber(pose, "camera.pose", "yaw_deg", 0.0);
}

// camera: frame rate, the renderer's noise, blur and exposure, and crf.
void ParseCameraExposure(const YAML::Node& node, std::uint64_t seed, CameraScenario* c) {
  const std::string path = "camera";
  c->fps = OptionalNumber(node, path, "fps", 30.0);
  if (!(c->fps > 0.0) || c->fps > 1000.0) Fail(node["fps"], "camera.fps", "must be in (0, 1000]");
  c->render.noise_sigma = OptionalNumber(node, path, "noise_sigma", 2.0);
  if (c->render.noise_sigma < 0.0) Fail(node["noise_sigma"], "camera.noise_sigma", "must not be negative");
  c->render.blur_sigma_px = OptionalNumber(node, path, "blur_sigma_px", 0.8);
  if (c->render.blur_sigma_px < 0.0) Fail(node["blur_sigma_px"], "camera.blur_sigma_px", "must not be negative");
  c->render.exposure_s = OptionalNumber(node, path, "exposure_ms", 4.0) * kMsToS;
  if (c->render.exposure_s < 0.0 || c->render.exposure_s * c->fps > 1.0)
    Fail(node["exposure_ms"], "camera.exposure_ms", "must be between 0 and one frame period");
  c->render.seed = seed;
  if (node["crf"]) {
    const long long crf = Integer(node["crf"], "camera.crf");
    if (crf < 0 || crf > 51) Fail(node["crf"], "camera.crf", "must be 0 to 51 (x264 CRF)");
    c->crf = static_cast<int>(crf);
    // A camera that records H.264 at this CRF: inter-coded, as cameras do
    // (the same as `codec: {h264: CRF}`).
    c->x264_preset = "veryfast";
    c->keyint = 0;
  }
}

void ParseImageFormation(const YAML::Node& node, CameraScenario* c) {
  const std::string path = "camera";
  vision::ImageFormationOptions& f = c->render.formation;
  // Image formation of a real camera (vision/image_formation.h):
  // a named profile, then any part given here on top of it. Without any of
  // these keys the renderer and the video are exactly as before.
  if (node["profile"]) {
    const std::string name = String(node["profile"], "camera.profile");
    const auto preset = vision::ImageFormationPreset(name);
    if (!preset) Fail(node["profile"], "camera.profile", "unknown '" + name + "' (expected machine-vision, webcam or phone)");
    f = *preset;
  }
  if (const YAML::Node psf = node["psf"]) {
    CheckKeys(psf, "camera.psf", {"model", "radius_px", "sigma_px"});
    vision::PsfOptions p;
    const std::string model = psf["model"] ? String(psf["model"], "camera.psf.model") : "gaussian";
    const auto parsed = vision::ParsePsfModel(model);
    if (!parsed) Fail(psf["model"], "camera.psf.model", "unknown '" + model + "' (expected gaussian, disk or disk+gaussian)");
    p.model = *parsed;
    p.radius_px = OptionalNumber(psf, "camera.psf", "radius_px", 0.0);
    p.sigma_px = OptionalNumber(psf, "camera.psf", "sigma_px", p.model == vision::PsfOptions::Model::kDisk ? 0.0 : 0.8);
    std::string why;
    if (!p.IsValid(&why)) Fail(psf, "camera.psf", why);
    f.psf = p;
  }
  if (node["rolling_shutter_ms"])
    f.rolling_shutter_s = Number(node["rolling_shutter_ms"], "camera.rolling_shutter_ms") * kMsToS;
  if (const YAML::Node bayer = node["bayer"]) {
    const std::string pattern = String(bayer, "camera.bayer");
    if (pattern != "rggb" && pattern != "none") Fail(bayer, "camera.bayer", "expected rggb or none");
    f.bayer = pattern == "rggb";
  }
  f.gamma = OptionalNumber(node, path, "gamma", f.gamma);
  f.vignetting = OptionalNumber(node, path, "vignetting", f.vignetting);
  f.light_gradient = OptionalNumber(node, path, "light_gradient", f.light_gradient);
  f.gain = OptionalNumber(node, path, "gain", f.gain);
  f.sharpen = OptionalNumber(node, path, "sharpen", f.sharpen);
  if (const YAML::Node noise = node["noise"]) {
    CheckKeys(noise, "camera.noise", {"read_e", "full_well_e"});
    vision::SensorNoiseOptions n;
    n.read_e = OptionalNumber(noise, "camera.noise", "read_e", n.read_e);
    n.full_well_e = OptionalNumber(noise, "camera.noise", "full_well_e", n.full_well_e);
    f.noise = n;
  }
  if (const YAML::Node codec = node["codec"]) {
    CheckKeys(codec, "camera.codec", {"h264", "mjpeg"});
    if (codec.size() != 1) Fail(codec, "camera.codec", "expected one of {h264: CRF} or {mjpeg: QUALITY}");
    if (codec["h264"]) {
      f.codec = {vision::CodecOptions::Kind::kH264, static_cast<int>(Integer(codec["h264"], "camera.codec.h264")), 80};
    } else {
      f.codec = {vision::CodecOptions::Kind::kMjpeg, 23, static_cast<int>(Integer(codec["mjpeg"], "camera.codec.mjpeg"))};
    }
  }
  if (node["crf"] && (node["codec"] || node["profile"]))
    Fail(node["crf"], "camera.crf", "give the codec once: crf, or codec/profile");
  // The video file is H.264 either way: MJPEG is applied frame by frame in
  // the renderer and then stored losslessly (CRF 0), so it is not coded twice.
  if (f.codec.kind == vision::CodecOptions::Kind::kH264) {
    c->crf = f.codec.crf;
    c->x264_preset = "veryfast";
    c->keyint = 0;
  }
  if (f.codec.kind == vision::CodecOptions::Kind::kMjpeg) c->crf = 0;
}

// camera.tag: the robot tag's print (scale, bow, black and white levels).
void ParseCameraTag(const YAML::Node& node, CameraScenario* c) {
  if (const YAML::Node tag = node["tag"]) {
    CheckKeys(tag, "camera.tag", {"print_scale", "bow_mm", "black_level", "white_level"});
    c->render.tag_bow_mm = OptionalNumber(tag, "camera.tag", "bow_mm", 0.0);
    if (!(c->render.tag_bow_mm >= 0.0 && c->render.tag_bow_mm <= 50.0))
      Fail(tag["bow_mm"], "camera.tag.bow_mm", "must be in [0, 50] (mm the paper's middle rises)");
    c->tag_print_scale = OptionalNumber(tag, "camera.tag", "print_scale", 1.0);
    if (!(c->tag_print_scale > 0.5 && c->tag_print_scale < 2.0))
      Fail(tag["print_scale"], "camera.tag.print_scale", "must be in (0.5, 2)");
    // Reflectances, as fractions of the full-scale white (grey 255 at unit gain).
    c->render.tag_black = 255.0 * OptionalNumber(tag, "camera.tag", "black_level", c->render.tag_black / 255.0);
    c->render.tag_white = 255.0 * OptionalNumber(tag, "camera.tag", "white_level", c->render.tag_white / 255.0);
    if (!(c->render.tag_black >= 0.0 && c->render.tag_black + 10.0 < c->render.tag_white))
      Fail(tag, "camera.tag", "black_level must be >= 0 and well below white_level");
  }
}

// camera.floor_tags: tags taped to the floor, the station's floor reference.
void ParseFloorTags(const YAML::Node& node, CameraScenario* c) {
  if (const YAML::Node floor = node["floor_tags"]) {
    const std::string fp = "camera.floor_tags";
    ExpectMap(floor, fp);
    CheckKeys(floor, fp, {"family", "size_mm", "tags", "tape_sigma_mm", "tape_error_mm"});
    CameraScenario::FloorTags ft;
    if (floor["family"]) ft.family = String(floor["family"], Join(fp, "family"));
    if (!vision::IsKnownTagFamily(ft.family))
      Fail(floor["family"], Join(fp, "family"), "unknown tag family '" + ft.family + "'");
    ft.size_mm = Positive(OptionalNumber(floor, fp, "size_mm", ft.size_mm), floor["size_mm"], Join(fp, "size_mm"));
    ft.tape_sigma_mm = Positive(OptionalNumber(floor, fp, "tape_sigma_mm", ft.tape_sigma_mm),
                                floor["tape_sigma_mm"], Join(fp, "tape_sigma_mm"));
    ft.tape_error_mm = OptionalNumber(floor, fp, "tape_error_mm", 0.0);
    const YAML::Node tags = floor["tags"];
    if (!tags || !tags.IsSequence() || tags.size() < 2)
      Fail(tags ? tags : floor, Join(fp, "tags"), "expected a list of at least two {id, x_mm, y_mm, yaw_deg}");
    for (size_t i = 0; i < tags.size(); ++i) {
      const std::string tp = Join(fp, "tags") + "[" + std::to_string(i) + "]";
      CheckKeys(tags[i], tp, {"id", "x_mm", "y_mm", "yaw_deg"});
      CameraScenario::FloorTags::Tag t;
      if (!tags[i]["id"]) Fail(tags[i], Join(tp, "id"), "missing (required)");
      t.id = static_cast<int>(Integer(tags[i]["id"], Join(tp, "id")));
      if (t.id < 0) Fail(tags[i]["id"], Join(tp, "id"), "must be a tag id (0 or more)");
      t.x_mm = RequiredNumber(tags[i], tp, "x_mm");
      t.y_mm = RequiredNumber(tags[i], tp, "y_mm");
      t.yaw_deg = OptionalNumber(tags[i], tp, "yaw_deg", 0.0);
      for (const auto& other : ft.tags)
        if (other.id == t.id) Fail(tags[i]["id"], Join(tp, "id"), "tag " + std::to_string(t.id) + " listed twice");
      ft.tags.push_back(t);
    }
    c->floor_tags = ft;
  }
}

CameraScenario ParseCamera(const YAML::Node& node, std::uint64_t seed) {
  const std::string path = "camera";
  // clang-format off
  CheckKeys(node, path,
            {"width", "height", "fx", "fy", "cx", "cy", "distortion", "distortion_model", "pose", "fps", "noise_sigma",
             "blur_sigma_px", "exposure_ms", "crf", "profile", "psf", "rolling_shutter_ms", "bayer",
             "gamma", "vignetting", "light_gradient", "gain", "sharpen", "noise", "codec", "tag",
             "floor_tags", "one_video"});
  // clang-format on
  CameraScenario c;
  if (node["one_video"]) c.one_video = Bool(node["one_video"], "camera.one_video");
  ParseCameraLens(node, &c);
  ParseCameraPose(node, &c);
  ParseCameraExposure(node, seed, &c);
  ParseImageFormation(node, &c);
  ParseCameraTag(node, &c);
  ParseFloorTags(node, &c);
  std::string formation_why;
  if (!c.render.formation.IsValid(&formation_why)) Fail(node, path, formation_why);
  return c;
}

// One entry of the scenario's `effects:` list, by name.
struct EffectEntry {
  YAML::Node e;
  std::string path;  // "effects[i]"
  std::string name;
  // Fails when the effect was already given (already: its value is set).
  void FailIfListedTwice(bool already) const {
    if (already) Fail(e, path, "effect '" + name + "' is listed twice");
  }
};

// The effects on the measurement (the tag's and the tracker's mounting, the camera's latency, lens and
// shutter); false when the entry is not one of them.
bool ParseSensorEffect(const EffectEntry& x, sim::Effects& out) {
  const YAML::Node& e = x.e;
  const std::string& path = x.path;
  const std::string& name = x.name;
  if (name == "tag_offset") {
    CheckKeys(e, path, {"name", "x_mm", "y_mm"});
    x.FailIfListedTwice(out.tag_offset.has_value());
    out.tag_offset =
        sim::TagOffsetEffect{RequiredNumber(e, path, "x_mm") * kMmToM, RequiredNumber(e, path, "y_mm") * kMmToM};
  } else if (name == "camera_latency") {
    CheckKeys(e, path, {"name", "ms"});
    x.FailIfListedTwice(out.camera_latency.has_value());
    out.camera_latency = sim::CameraLatencyEffect{RequiredNumber(e, path, "ms") * kMsToS};
  } else if (name == "lens_distortion") {
    CheckKeys(e, path, {"name", "k1"});
    x.FailIfListedTwice(out.lens_distortion.has_value());
    out.lens_distortion = sim::LensDistortionEffect{RequiredNumber(e, path, "k1")};
  } else if (name == "tracker_yaw") {
    CheckKeys(e, path, {"name", "deg"});
    x.FailIfListedTwice(out.tracker_yaw.has_value());
    const double deg = RequiredNumber(e, path, "deg");
    if (std::abs(deg) >= 45.0) Fail(e["deg"], Join(path, "deg"), "must be within (-45, 45)");
    out.tracker_yaw = sim::TrackerYawEffect{deg * kDegToRad};
  } else if (name == "rolling_shutter") {
    CheckKeys(e, path, {"name", "ms"});
    x.FailIfListedTwice(out.rolling_shutter.has_value());
    // The readout of the rows, top to bottom (as camera.rolling_shutter_ms).
    const double ms = RequiredNumber(e, path, "ms");
    if (!(ms >= 0.0 && ms <= 1000.0)) Fail(e["ms"], Join(path, "ms"), "must be in [0, 1000]");
    out.rolling_shutter = sim::RollingShutterEffect{ms * kMsToS};
  } else {
    return false;
  }
  return true;
}

// The effects on the robot's motion and its encoders (slips, backlash, carpet, wheels out of round);
// false when the entry is not one of them.
bool ParseDriveEffect(const EffectEntry& x, sim::Effects& out) {
  const YAML::Node& e = x.e;
  const std::string& path = x.path;
  const std::string& name = x.name;
  if (name == "turn_slip") {
    CheckKeys(e, path, {"name", "fraction_at_1rad_s"});
    x.FailIfListedTwice(out.turn_slip.has_value());
    const double f = RequiredNumber(e, path, "fraction_at_1rad_s");
    if (f < 0.0 || f >= 0.5) Fail(e["fraction_at_1rad_s"], Join(path, "fraction_at_1rad_s"), "must be in [0, 0.5)");
    out.turn_slip = sim::TurnSlipEffect{f};
  } else if (name == "encoder_backlash") {
    CheckKeys(e, path, {"name", "ticks"});
    x.FailIfListedTwice(out.encoder_backlash.has_value());
    const double ticks = RequiredNumber(e, path, "ticks");
    if (ticks < 0.0) Fail(e["ticks"], Join(path, "ticks"), "must not be negative");
    out.encoder_backlash = sim::EncoderBacklashEffect{ticks};
  } else if (name == "carpet_drift") {
    CheckKeys(e, path, {"name", "grain_deg", "rate_mm_per_m"});
    x.FailIfListedTwice(out.carpet_drift.has_value());
    out.carpet_drift = sim::CarpetDriftEffect{RequiredNumber(e, path, "grain_deg") * kDegToRad,
                                              RequiredNumber(e, path, "rate_mm_per_m") * kMmToM};
  } else if (name == "speed_slip") {
    CheckKeys(e, path, {"name", "fraction_at_1m_s"});
    x.FailIfListedTwice(out.speed_slip.has_value());
    const double k = RequiredNumber(e, path, "fraction_at_1m_s");
    if (k < 0.0 || k >= 0.5) Fail(e["fraction_at_1m_s"], Join(path, "fraction_at_1m_s"), "must be in [0, 0.5)");
    out.speed_slip = sim::SpeedSlipEffect{k};
  } else if (name == "arc_scale") {
    CheckKeys(e, path, {"name", "fraction_at_1_per_m"});
    x.FailIfListedTwice(out.arc_scale.has_value());
    // Loss c |kappa|: below 0.1 on a circle of radius 0.1 m.
    const double c = RequiredNumber(e, path, "fraction_at_1_per_m");
    if (c < 0.0 || c >= 0.01) Fail(e["fraction_at_1_per_m"], Join(path, "fraction_at_1_per_m"), "must be in [0, 0.01)");
    out.arc_scale = sim::ArcScaleEffect{c};
  } else if (name == "eccentric_wheel" || name == "oval_wheel") {
    // One wheel's radius r (1 + a sin(k phi + phase)): once a turn
    // (eccentric), or twice (oval, simulator only).
    std::optional<sim::EccentricWheelEffect>& wheel_effect =
        name == "eccentric_wheel" ? out.eccentric_wheel : out.oval_wheel;
    CheckKeys(e, path, {"name", "wheel", "amplitude", "phase_deg"});
    x.FailIfListedTwice(wheel_effect.has_value());
    if (!e["wheel"]) Fail(e, Join(path, "wheel"), "missing (required: left or right)");
    const std::string wheel = String(e["wheel"], Join(path, "wheel"));
    if (wheel != "left" && wheel != "right") Fail(e["wheel"], Join(path, "wheel"), "must be left or right");
    const double a = RequiredNumber(e, path, "amplitude");
    if (a < 0.0 || a >= 0.2) Fail(e["amplitude"], Join(path, "amplitude"), "must be in [0, 0.2)");
    wheel_effect = sim::EccentricWheelEffect{wheel == "left", a, OptionalNumber(e, path, "phase_deg", 0.0) * kDegToRad};
  } else {
    return false;
  }
  return true;
}

sim::Effects ParseEffects(const YAML::Node& effects) {
  if (!effects.IsSequence()) Fail(effects, "effects", "expected a list");
  sim::Effects out;
  for (size_t i = 0; i < effects.size(); ++i) {
    const YAML::Node e = effects[i];
    const std::string path = "effects[" + std::to_string(i) + "]";
    ExpectMap(e, path);
    if (!e["name"]) Fail(e, Join(path, "name"), "missing (required)");
    const EffectEntry entry{e, path, String(e["name"], Join(path, "name"))};
    if (!ParseSensorEffect(entry, out) && !ParseDriveEffect(entry, out))
      Fail(e["name"], Join(path, "name"),
           "unknown effect '" + entry.name +
               "' (expected tag_offset, camera_latency, turn_slip, lens_distortion, "
               "encoder_backlash, carpet_drift, tracker_yaw, speed_slip, arc_scale, "
               "rolling_shutter, eccentric_wheel, oval_wheel)");
  }
  return out;
}

}  // namespace

namespace {

// The parser; the public function wraps its error line in a Result.
std::optional<Scenario> LoadScenarioOrError(const std::string& path, std::string* error) {
  auto fail = [&](const std::string& message) -> std::optional<Scenario> {
    if (error) *error = message;
    return std::nullopt;
  };
  if (!std::filesystem::exists(path)) return fail(path + ": no such file");
  if (std::filesystem::is_directory(path)) return fail(path + ": is a directory, not a scenario file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    return fail(path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!root || root.IsNull()) return fail(path + ": empty scenario file");
  try {
    CheckKeys(root, "", {"seed", "robot", "runs", "effects", "tag", "camera"});
    Scenario s;
    s.path = path;
    if (const YAML::Node seed = root["seed"]) {
      const long long value = Integer(seed, "seed");
      if (value < 0) Fail(seed, "seed", "must not be negative");
      s.seed = static_cast<std::uint64_t>(value);
    }
    if (!root["robot"]) Fail(root, "robot", "missing (required)");
    s.robot = ParseRobot(root["robot"]);
    s.robot.seed = s.seed;
    const YAML::Node runs = root["runs"];
    if (!runs) Fail(root, "runs", "missing (required)");
    if (!runs.IsSequence() || runs.size() == 0) Fail(runs, "runs", "expected a non-empty list of runs");
    for (size_t i = 0; i < runs.size(); ++i) {
      const std::string rp = "runs[" + std::to_string(i) + "]";
      s.runs.push_back(ParseRun(runs[i], rp));
      // A recorded run has no plan for the virtual robot to drive.
      if (s.runs.back().procedure == calibration::Procedure::kRecorded)
        Fail(runs[i]["procedure"], Join(rp, "procedure"),
             "a scenario cannot simulate a recorded run (no plan to drive); use a planned procedure");
    }
    if (const YAML::Node effects = root["effects"]) s.robot.effects = ParseEffects(effects);
    if (root["tag"].IsDefined() != root["camera"].IsDefined()) {
      Fail(root, root["tag"] ? "camera" : "tag",
           "missing: a scenario with a camera needs a tag on the robot, and the other way round");
    }
    if (const YAML::Node tag = root["tag"]) s.tag = ParseTag(tag);
    if (const YAML::Node camera = root["camera"]) s.camera = ParseCamera(camera, s.seed);
    // One shutter, named once: the hidden effect is rendered as the camera's.
    if (s.robot.effects.rolling_shutter && root["camera"] && root["camera"]["rolling_shutter_ms"])
      Fail(root["camera"]["rolling_shutter_ms"], "camera.rolling_shutter_ms",
           "the effects list has rolling_shutter: give the readout once (the effect is rendered "
           "as the camera's rolling shutter)");
    return s;
  } catch (const YamlError& e) {
    return fail(path + ":" + e.what());
  } catch (const YAML::Exception& e) {
    return fail(path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

}  // namespace

std::string RunName(int index, const calibration::RunSpec& spec) {
  char name[64];
  const bool has_direction = spec.procedure != calibration::Procedure::kStraight &&
                             spec.procedure != calibration::Procedure::kRecorded;
  std::snprintf(name, sizeof(name), "run%02d_%s%s%s", index + 1,
                std::string(calibration::ToString(spec.procedure)).c_str(), has_direction ? "_" : "",
                has_direction ? std::string(calibration::ToString(spec.direction)).c_str() : "");
  return name;
}

Result<Scenario> LoadScenario(const std::string& path) {
  return ReadFileAs<Scenario>(path, [&](std::string* error) { return LoadScenarioOrError(path, error); });
}

}  // namespace odocal::config
