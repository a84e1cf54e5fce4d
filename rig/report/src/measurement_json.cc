#include "odocal/report/measurement_json.h"

#include <algorithm>
#include <vector>

#include "odocal/base/units.h"

namespace odocal::report {

using json = nlohmann::json;

nlohmann::json RunJson(const measure::RunMeasurement& rm) {
  const calibration::MeasuredRun& m = rm.measured;
  nlohmann::json j = {{"name", m.name},
                      {"procedure", calibration::ToString(m.spec.procedure)},
                      {"direction", calibration::ToString(m.spec.direction)}};
  if (rm.pose_log) {
    j["source"] = "poses";
    j["poses"] = rm.run.poses;
  } else {
    j["source"] = "video";
    j["video"] = rm.run.video;
  }
  if (const calibration::RelativePose* usable = measure::UsableReturnError(m)) {
    const calibration::RelativePose& r = *usable;
    j["return_error"] = {{"x_mm", r.pose.x() * kMToMm}, {"y_mm", r.pose.y() * kMToMm},
                         {"theta_deg", r.pose.heading() * kRadToDeg}};
    j["sigma"] = {{"x_mm", r.sigma_x_m() * kMToMm}, {"y_mm", r.sigma_y_m() * kMToMm},
                  {"theta_deg", r.sigma_heading_rad() * kRadToDeg}};
  } else {
    j["return_error"] = nullptr;
    j["sigma"] = nullptr;
  }
  j["flags"] = calibration::ToStrings(m.flags);
  if (rm.pose_log) {
    const measure::PoseLogStats& p = *rm.pose_log;
    j["frames"] = {{"logged", p.rows}, {"valid", p.valid}, {"nan", p.nan_rows},
                   {"tracker_jump", p.jump_frames},
                   {"start_rest", m.start_rest ? m.start_rest->n : 0},
                   {"end_rest", m.end_rest ? m.end_rest->n : 0}};
    j["pose_period_s"] = p.pose_period_s;
    j["clock_offset_s"] = p.clock_offset_s ? nlohmann::json(*p.clock_offset_s) : nlohmann::json(nullptr);
    j["unit_check"] = {{"path_ratio", p.path_ratio}, {"heading_ratio", p.heading_ratio}};
    return j;
  }
  int searched = 0;
  for (const auto& f : rm.track.frames) searched += f.searched ? 1 : 0;
  j["frames"] = {{"decoded", rm.track.frames.size()}, {"tag_found", rm.track.found},
                 {"searched", searched},
                 {"start_rest", m.start_rest ? m.start_rest->n : 0},
                 {"end_rest", m.end_rest ? m.end_rest->n : 0}};
  // What the images were like at the rests (medians; each refined frame
  // under per_frame): tag size, contrast, blur, tone, saturation.
  if (rm.start_quality || rm.end_quality) {
    j["quality"] = {{"start_rest", rm.start_quality ? RestQualityJson(*rm.start_quality) : nlohmann::json()},
                    {"end_rest", rm.end_quality ? RestQualityJson(*rm.end_quality) : nlohmann::json()}};
  }
  return j;
}

nlohmann::json RestQualityJson(const measure::RestQuality& q) {
  auto entry = [](const vision::TagImageQuality& m) {
    return nlohmann::json{{"tag_side_px", m.side_px},
                          {"contrast_grey", m.contrast_grey},
                          {"blur_sigma_px", m.blur_sigma_px},
                          {"saturated_fraction", m.saturated_fraction},
                          {"edge_residual_grey", m.rms_residual_grey}};
  };
  nlohmann::json frames = nlohmann::json::array();
  for (const measure::FrameQuality& f : q.per_frame) {
    nlohmann::json j = f.fitted ? entry(f.quality) : nlohmann::json::object();
    j["t_s"] = f.t_s;
    j["flags"] = vision::ToStrings(f.flags);
    frames.push_back(j);
  }
  nlohmann::json j = entry(q.median);
  j["frames"] = q.frames;
  j["usable_frames"] = q.usable;
  j["shared_error_mm"] = q.shared_error_mm;
  j["independent_error_mm"] = q.independent_error_mm;
  j["flags"] = vision::ToStrings(q.flags);
  j["per_frame"] = frames;
  return j;
}

nlohmann::json TrajectoryJson(const measure::RunMeasurement& rm, int max_points) {
  std::vector<const calibration::CameraRecord*> valid;
  for (const calibration::CameraRecord& c : rm.measured.camera)
    if (c.valid) valid.push_back(&c);
  json points = json::array();
  const size_t step = std::max<size_t>(1, (valid.size() + max_points - 1) / std::max(1, max_points));
  for (size_t i = 0; i < valid.size(); i += step)
    points.push_back({valid[i]->T_world_robot.x() * kMToMm, valid[i]->T_world_robot.y() * kMToMm});
  if (!valid.empty() && (valid.size() - 1) % step != 0)
    points.push_back({valid.back()->T_world_robot.x() * kMToMm, valid.back()->T_world_robot.y() * kMToMm});
  return {{"name", rm.measured.name},
          {"procedure", calibration::ToString(rm.measured.spec.procedure)},
          {"direction", calibration::ToString(rm.measured.spec.direction)},
          {"points_mm", points}};
}

nlohmann::json PlaneJson(const measure::SessionMeasurement& sm) {
  if (!sm.session.has_camera) return nullptr;  // pose logs only: no camera to place
  if (!sm.plane_estimated) return {{"estimated", false}, {"message", sm.plane.message}};
  const vision::CameraPlaneResult& p = sm.plane;
  return {{"estimated", true},
          {"roll_deg", p.mount.roll_deg},
          {"pitch_deg", p.mount.pitch_deg},
          {"height_mm", p.mount.height_mm},
          {"sigma", {{"roll_deg", p.sigma_roll_deg}, {"pitch_deg", p.sigma_pitch_deg},
                     {"height_mm", p.sigma_height_mm}}},
          {"views", p.views_used},
          {"rms_reprojection_px", p.rms_reprojection_px},
          // null: the views did not move enough to tell a rolling shutter
          {"rolling_shutter_ms", p.rolling_shutter_fitted ? nlohmann::json(p.rolling_shutter_ms) : nlohmann::json()},
          {"sigma_rolling_shutter_ms",
           p.rolling_shutter_fitted ? nlohmann::json(p.sigma_rolling_shutter_ms) : nlohmann::json()}};
}

nlohmann::json CameraScaleJson(const measure::SessionMeasurement& sm) {
  if (!sm.session.has_camera) return nullptr;
  return CameraScaleJson(sm.camera_scale);
}

nlohmann::json CameraScaleJson(const measure::CameraScale& c) {
  nlohmann::json j = {{"source", std::string(measure::ToString(c.source))},
                      {"relative_sigma", c.relative_sigma},
                      {"camera_height_mm", c.camera_height_mm},
                      {"sigma_camera_height_mm", c.sigma_camera_height_mm},
                      {"explanation", c.explanation}};
  if (c.edge_shift.ok())
    j["edge_shift"] = {{"shift_px", c.edge_shift.shift_px},
                       {"sigma_px", c.edge_shift.sigma_px},
                       {"spread_px", c.edge_shift.spread_px},
                       {"views", c.edge_shift.views},
                       {"tag_side_px", c.edge_shift.side_px},
                       {"scale_error_removed", c.edge_shift.RelativeScaleError()},
                       {"meaning", "how far the tag's black/white edges lie outside (+) the print in its image "
                                   "(tone curve, blur, ink), measured inside the tag and removed from the plane's views"}};
  if (!c.with_floor_reference) return j;
  nlohmann::json tags = nlohmann::json::array();
  for (const vision::FloorTagSighting& t : c.floor_tags) {
    nlohmann::json tag = {{"id", t.id},
                          {"frames_seen", t.frames_seen},
                          {"frames_used", t.frames_used},
                          {"flags", vision::ToStrings(t.flags)}};
    if (t.usable()) {
      tag["centre_px"] = {t.centre_px.x, t.centre_px.y};
      tag["sigma_centre_px"] = t.sigma_centre_px;
      tag["quality"] = {{"side_px", t.median_quality.side_px},
                        {"contrast_grey", t.median_quality.contrast_grey},
                        {"blur_sigma_px", t.median_quality.blur_sigma_px},
                        {"saturated_fraction", t.median_quality.saturated_fraction},
                        {"rms_residual_grey", t.median_quality.rms_residual_grey}};
    }
    tags.push_back(tag);
  }
  j["floor_tags"] = tags;
  if (c.floor) {
    const vision::FloorScaleResult& f = *c.floor;
    nlohmann::json reference = {{"ok", f.ok()}};
    if (!f.ok()) reference["message"] = f.message;
    if (f.ok()) {
      nlohmann::json pairs = nlohmann::json::array();
      for (const auto& p : f.pairs)
        pairs.push_back({{"between", {p.id_a, p.id_b}},
                         {"tape_mm", p.tape_mm},
                         {"tape_sigma_mm", p.tape_sigma_mm},
                         {"seen_mm", p.seen_mm},
                         {"sigma_seen_mm", p.sigma_seen_mm},
                         {"camera_height_mm", p.height_mm}});
      reference["distances"] = pairs;
      reference["camera_height_mm"] = f.camera_height_mm;
      reference["sigma_camera_height_mm"] = f.sigma_camera_height_mm;
      reference["variance_share"] = {{"tape", f.variance_share_tape},
                                     {"centres", f.variance_share_centres},
                                     {"tilt", f.variance_share_tilt}};
      reference["chi_square"] = f.chi_square;
      reference["inconsistent"] = f.inconsistent;
    }
    j["floor_reference"] = reference;
  }
  if (c.tag_print_scale)
    j["tag_print_scale"] = {{"value", *c.tag_print_scale},
                            {"sigma", *c.tag_print_scale_sigma},
                            {"meaning", "robot tag's apparent size / stated size (1.0042: prints 0.42 % large)"}};
  return j;
}

}  // namespace odocal::report
