#include "odocal/simulation/camera_sim.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <mutex>

#include "odocal/base/parallel.h"
#include "odocal/base/units.h"
#include "odocal/config/files.h"
#include "odocal/media/video.h"
#include "odocal/sim/trajectory.h"

namespace odocal::simulation {
namespace {


// Records `runs` (consecutive in the robot's time) as one video `name`.
Status RecordOne(const config::Scenario& scenario, const std::vector<const sim::RunRecord*>& runs,
                 const std::string& name, const std::string& dir, RecordedRun* out) {
  const config::CameraScenario& cam = *scenario.camera;
  const sim::Effects& effects = scenario.robot.effects;
  // The world as it is, not as the operator's files say.
  vision::TagSpec true_tag = *scenario.tag;
  true_tag.size_mm *= cam.tag_print_scale;  // as printed, not as stated
  if (effects.tag_offset) {
    true_tag.offset_x_mm = effects.tag_offset->x_m * kMToMm;
    true_tag.offset_y_mm = effects.tag_offset->y_m * kMToMm;
  }
  if (effects.tracker_yaw) true_tag.yaw_deg += effects.tracker_yaw->yaw_rad * kRadToDeg;
  vision::Intrinsics true_lens = cam.intrinsics;
  if (effects.lens_distortion) true_lens.distortion[0] += effects.lens_distortion->k1_delta;
  const double latency_s = effects.camera_latency ? effects.camera_latency->latency_s : 0.0;

  vision::RenderOptions render = cam.render;
  // A hidden rolling shutter is the camera's (it replaces a profile's readout).
  if (effects.rolling_shutter) render.formation.rolling_shutter_s = effects.rolling_shutter->readout_s;
  render.seed = scenario.seed * 1000003ULL + std::hash<std::string>{}(name);
  render.floor_tags = FloorTagPlacements(cam);
  vision::RendererResult created =
      vision::Renderer::Create(vision::CameraModel(true_lens, cam.mount), true_tag, render);
  if (!created.ok()) return Status::Error(created.status, name + ": cannot render: " + created.message);
  vision::Renderer& renderer = *created.renderer;

  out->video = dir + "/" + name + ".mp4";
  out->timestamps = dir + "/" + name + ".timestamps.csv";
  out->frames = dir + "/" + name + ".frames.csv";
  media::Mp4Writer writer;
  media::Mp4WriterOptions writer_options;
  writer_options.backend = media::Mp4WriterOptions::Backend::kFfmpegCli;
  writer_options.crf = cam.crf;
  writer_options.preset = cam.x264_preset;
  writer_options.keyint = cam.keyint;
  const odocal::Status opened =
      writer.Open(out->video, cam.fps, cv::Size(cam.intrinsics.width, cam.intrinsics.height),
                  writer_options);
  if (!opened.ok()) return opened;

  std::string truth =
      "frame,t_capture_s,stamp_s,visible,robot_x_mm,robot_y_mm,robot_heading_deg,tag_x_mm,"
      "tag_y_mm,tag_heading_deg,c0x,c0y,c1x,c1y,c2x,c2y,c3x,c3y\n";
  const auto trajectory = [&runs](double t) {
    size_t k = 0;
    while (k + 1 < runs.size() && t >= runs[k + 1]->start_time_s) ++k;
    return sim::PoseAt(*runs[k], t);
  };
  const double start_s = runs.front()->start_time_s, end_s = runs.back()->end_time_s;
  const int frame_count = static_cast<int>(std::floor((end_s - start_s) * cam.fps + 1e-9)) + 1;
  char line[512];
  for (int k = 0; k < frame_count; ++k) {
    const double t = start_s + k / cam.fps;
    const vision::RenderedFrame frame = renderer.RenderExposure(trajectory, t);
    const double stamp = t - latency_s;
    const odocal::Status wrote = writer.Write(frame.image, stamp);
    if (!wrote.ok()) return wrote;
    const auto& c = frame.corners_px;
    std::snprintf(line, sizeof(line),
                  "%d,%.6f,%.6f,%d,%.5f,%.5f,%.6f,%.5f,%.5f,%.6f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f\n",
                  k, t, stamp, frame.tag_visible ? 1 : 0, frame.T_world_robot.x() * kMToMm,
                  frame.T_world_robot.y() * kMToMm, frame.T_world_robot.heading() * kRadToDeg,
                  frame.T_world_tag.x() * kMToMm, frame.T_world_tag.y() * kMToMm,
                  frame.T_world_tag.heading() * kRadToDeg, c[0].x, c[0].y, c[1].x, c[1].y, c[2].x,
                  c[2].y, c[3].x, c[3].y);
    truth += line;
    out->frames_visible += frame.tag_visible ? 1 : 0;
    if (k == 0) out->start_s = stamp;
    out->end_s = stamp;
  }
  out->frames_written = frame_count;
  const odocal::Status closed = writer.Close();
  if (!closed.ok()) return closed;
  const odocal::Status stamps = writer.WriteTimestamps(out->timestamps);
  if (!stamps.ok()) return stamps;
  return config::WriteFileAtomically(out->frames, truth);
}

}  // namespace

std::vector<vision::FloorTagPlacement> FloorTagPlacements(const config::CameraScenario& cam) {
  std::vector<vision::FloorTagPlacement> placements;
  if (!cam.floor_tags) return placements;
  for (const auto& t : cam.floor_tags->tags) {
    vision::FloorTagPlacement placement;
    placement.family = cam.floor_tags->family;
    placement.id = t.id;
    placement.size_mm = cam.floor_tags->size_mm * cam.tag_print_scale;  // the same printer
    placement.T_world_tag = calibration::Pose2::FromXYHeading(t.x_mm * kMmToM, t.y_mm * kMmToM, t.yaw_deg * kDegToRad);
    placements.push_back(placement);
  }
  return placements;
}

vision::FloorReference TapedFloorReference(const config::CameraScenario::FloorTags& ft,
                                           std::vector<double>* true_mm) {
  vision::FloorReference reference;
  reference.family = ft.family;
  for (const auto& t : ft.tags) reference.tags.push_back({t.id, ft.size_mm});
  const size_t n = ft.tags.size();
  for (size_t i = 0; i < (n > 2 ? n : 1); ++i) {
    const auto& a = ft.tags[i];
    const auto& b = ft.tags[(i + 1) % n];
    const double truth_mm = std::hypot(b.x_mm - a.x_mm, b.y_mm - a.y_mm);
    // Read to a tenth of a millimetre.
    const double reading_mm = std::round((truth_mm + ft.tape_error_mm) * 10.0) / 10.0;
    reference.distances.push_back({a.id, b.id, reading_mm, ft.tape_sigma_mm});
    if (true_mm) true_mm->push_back(truth_mm);
  }
  return reference;
}

Status RecordRuns(const config::Scenario& scenario, const SimulationResult& result, const std::string& dir,
                  bool progress, std::vector<RecordedRun>* recorded) {
  if (!scenario.camera || !scenario.tag)
    return Status::Error(StatusCode::kInvalidArgument, "scenario has no camera and tag");
  const size_t n = result.runs.size();
  recorded->assign(n, RecordedRun{});
  if (scenario.camera->one_video) {
    // One video for the whole plan (a single encoder: no parallelism).
    std::vector<const sim::RunRecord*> runs;
    for (const sim::RunRecord& r : result.runs) runs.push_back(&r);
    RecordedRun all;
    if (Status e = RecordOne(scenario, runs, "recording", dir, &all); !e) return e;
    for (size_t i = 0; i < n; ++i) {
      (*recorded)[i] = all;
      (*recorded)[i].start_s = result.runs[i].start_time_s;
      (*recorded)[i].end_s = result.runs[i].end_time_s;
    }
    if (progress) std::cerr << "recorded " << n << " runs in one video (" << all.frames_written << " frames)\n";
    return Status::Ok();
  }
  std::vector<Status> errors(n);
  std::atomic<size_t> done{0};
  std::mutex print;
  ParallelFor(n, 0, [&](size_t i) {
    errors[i] = RecordOne(scenario, {&result.runs[i]}, result.run_names[i], dir, &(*recorded)[i]);
    const size_t finished = ++done;
    if (progress) {
      std::lock_guard<std::mutex> lock(print);
      std::cerr << "recorded " << finished << "/" << n << ": " << result.run_names[i] << " ("
                << (*recorded)[i].frames_written << " frames)\n";
    }
  });
  for (const Status& e : errors)
    if (!e) return e;
  return Status::Ok();
}

vision::CameraMount OperatorMountGuess(const vision::CameraMount& truth) {
  vision::CameraMount guess;
  guess.x_mm = std::round(truth.x_mm / 100.0) * 100.0;
  guess.y_mm = std::round(truth.y_mm / 100.0) * 100.0;
  guess.height_mm = std::round(truth.height_mm / 100.0) * 100.0;
  guess.yaw_deg = std::round(truth.yaw_deg / 90.0) * 90.0;
  return guess;
}

}  // namespace odocal::simulation
