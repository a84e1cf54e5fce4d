// A length the camera can trust: tags lying on the floor at distances
// measured once with a tape or a steel rule.
//
// Without it, the camera's scale comes from the robot tag's apparent size:
// the plane estimate (planar_pose.h) puts the camera at the height where a
// tag of the stated size looks as big as it does. A printer that scales by
// 0.5 %, or a tone curve that shrinks the black square (docs/vision.md),
// makes that height, every distance and Es 0.5 % wrong.
//
// With it: the rays through two floor-tag centres meet the floor (z = 0) at
// points whose distance is exactly proportional to the camera's height above
// the floor, whatever the tilt (the floor points are C + s d with
// s = -C_z / d_z, so P_a - P_b = C_z (d_a / -d_az - d_b / -d_bz)). The tape's
// distance therefore fixes the height:
//     H = H0 * D_tape / D(H0)
// for any trial height H0, one value per measured pair, combined by inverse
// variance. Only the tags' centres are used, never their sizes: a centre
// (the intersection of the undistorted diagonals, which perspective keeps at
// the square's centre) does not move when the print is scaled or the tone
// curve thickens the black border, so the floor tags may come from the same
// bad printer. The tilt comes from the plane estimate (tilt does not depend
// on any length); its sigma enters H's.
//
// Uncertainty of H (1 sigma): the tape's sigma, each centre's (the spread of
// its per-frame centres over sqrt(n), and a floor of kCentreFloorPx for
// what the frames share), and the plane's roll and pitch sigmas, each
// propagated by finite differences; in quadrature. Two or more pairs that
// disagree beyond their sigmas (a tag that moved, a misread tape) are
// reported, not averaged away.
//
// Frames: world REP-103 (floor z = 0); pixels OpenCV's.
#ifndef ODOCAL_VISION_FLOOR_REFERENCE_H_
#define ODOCAL_VISION_FLOOR_REFERENCE_H_

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/edge_quality.h"

namespace odocal::vision {

// What the operator states (session/station file, `floor_reference:`).
struct FloorReference {
  std::string family = "tag36h11";
  struct Tag {
    int id = 0;
    double size_mm = 0.0;  // as stated: guides the corner refinement only
  };
  std::vector<Tag> tags;
  // Centre-to-centre distances measured on the floor.
  struct Distance {
    int id_a = 0, id_b = 0;
    double mm = 0.0;
    double sigma_mm = 0.5;  // a tape read to the millimetre; 0.1 for a steel rule
  };
  std::vector<Distance> distances;
  // How well the robot tag's face height above the floor is known: it turns
  // the camera's height above the floor into its height above the tag plane.
  double tag_height_sigma_mm = 0.5;

  bool IsValid(std::string* why) const;
};

// A systematic floor on a floor tag's mean centre (px): what its frames
// share and averaging cannot remove. The refined corners of a static tag are
// unbiased to 0.01 px on clean frames, but a webcam's codec leaves errors
// common to every frame of a still scene: the webcam preset's rests are off
// by 0.06 mm on average at 1080p (0.045 px; docs/vision.md), and floor-tag
// centres through MJPEG q80 by up to 0.07 px (floor_reference_test).
inline constexpr double kCentreFloorPx = 0.05;

// One floor tag's centre, averaged over the frames that saw it well.
struct FloorTagSighting {
  int id = 0;
  int frames_seen = 0;  // detected
  int frames_used = 0;  // refined and passing the quality gate
  cv::Point2d centre_px;          // distorted pixel of the mean centre
  double sigma_centre_px = 0.0;   // of the mean, per axis, floor included
  TagImageQuality median_quality;
  std::vector<ObservationFlag> flags;  // why it was not used (not_seen, duplicate_id, the quality gate's)
  bool usable() const { return flags.empty(); }
};

// The floor tags in `frames` (grey, CV_8UC1): full-frame detection, the PSF-
// and tone-free corner refinement, the centre from the undistorted
// diagonals. A tag seen twice in one frame is ambiguous and not used.
std::vector<FloorTagSighting> ObserveFloorTags(const std::vector<cv::Mat>& frames,
                                               const Intrinsics& intrinsics,
                                               const FloorReference& reference,
                                               const QualityGate& gate = {});

struct FloorScaleResult {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;            // why not, when !ok()
  double camera_height_mm = 0.0;  // above the floor
  double sigma_camera_height_mm = 0.0;
  // Share of the height's variance by source (they add up to 1).
  double variance_share_tape = 0.0, variance_share_centres = 0.0, variance_share_tilt = 0.0;
  struct Pair {
    int id_a = 0, id_b = 0;
    double tape_mm = 0.0, tape_sigma_mm = 0.0;
    double seen_mm = 0.0;      // the camera's distance at the result's height
    double sigma_seen_mm = 0.0;  // from the centres alone
    double height_mm = 0.0;    // what this pair alone says
  };
  std::vector<Pair> pairs;
  // Chi-square of the pairs' heights about the result (pairs - 1 degrees of
  // freedom); `inconsistent` when its p-value is below 0.001.
  double chi_square = 0.0;
  bool inconsistent = false;
};

// The camera's height above the floor from the sightings, with `camera`'s
// tilt (its roll and pitch, with these sigmas) and any trial height.
FloorScaleResult EstimateFloorScale(const CameraModel& camera,
                                    const std::vector<FloorTagSighting>& sightings,
                                    const FloorReference& reference, double sigma_roll_deg,
                                    double sigma_pitch_deg);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_FLOOR_REFERENCE_H_
