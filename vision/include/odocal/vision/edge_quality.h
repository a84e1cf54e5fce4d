// Corner refinement that assumes neither the camera's PSF nor its tone curve,
// and the image quality that says whether a measurement can be trusted.
//
// Why: RefineTagCornersByEdgeModel fits a Gaussian-blurred edge in linear
// light. A real camera blurs by a defocus disk (or disk + Gaussian), encodes
// with a tone curve (gamma ~2.2), demosaics and compresses. An estimator
// exact for one PSF is biased for another, and on edges parallel to the
// pixel grid the bias depends on the edge's sub-pixel phase, so opposite
// edges of the tag move differently and the tag's centre and heading move.
//
// Here each edge's pixels are fitted by
//     value = g(a + b * S(d)),  g(x) = 255 (x / 255)^(1 / gamma),
// d the pixel centre's signed distance to the edge line, S the pixel-area
// mean of a symmetric edge-spread function: a mixture of two Gaussian ESFs,
// (1 - w) Phi(d / s1) + w Phi(d / s2), w free (w < 0 gives the overshoot of
// a sharpened image, a disk's flat-topped spread is close to two Gaussians).
// The edge is the centre of symmetry of the linear-light profile, which is
// where any symmetric PSF puts it; the tone curve is fitted per edge, so a
// monotonic power-law tone curve, gamma, vignetting and an uneven light
// (different levels on each edge) do not move it. What the model cannot
// represent (a tone curve that is not a power law, demosaicing, sharpening on
// encoded values) leaves a bias common to all four edges of the same
// polarity: the tag looks a little larger or smaller, its centre and heading
// do not move.
//
// Pixels: OpenCV convention; `grey` may be a crop whose pixel (0, 0) is image
// pixel `origin`. Measured: docs/vision.md ("Images odocal did not design").
#ifndef ODOCAL_VISION_EDGE_QUALITY_H_
#define ODOCAL_VISION_EDGE_QUALITY_H_

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/format.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/corner_refine.h"

namespace odocal::vision {

// What the pixels of a tag's four outer edges say about the image.
struct TagImageQuality {
  double side_px = 0.0;             // mean side of the black square
  double cell_px = 0.0;             // side / 8 for tag36h11
  double contrast_grey = 0.0;       // weakest edge: light minus dark, 8-bit levels
  double blur_sigma_px = 0.0;       // widest edge: the ESF's per-axis sigma
  double gamma = 1.0;               // mean of the fitted tone exponents
  double saturated_fraction = 0.0;  // band pixels at 0 or 255
  double rms_residual_grey = 0.0;   // worst edge's fit residual
  double relative_residual = 0.0;   // rms_residual_grey / contrast_grey
};

// When the image cannot support a measurement at the stated sigma.
struct QualityGate {
  // Below this the edge's location noise (~ noise / slope) is several times
  // the 0.01 px the stated sigmas assume at 2-3 grey levels of noise.
  double min_contrast_grey = 40.0;
  // The fit's band reaches 0.45 cell either side of the edge: an edge
  // blurred wider than this fraction of a cell has no plateau inside it,
  // and its levels (hence its location) are no longer determined.
  double max_blur_cells = 0.25;
  // Clipped pixels flatten one side of the profile: the symmetry the
  // estimator relies on is gone.
  double max_saturated_fraction = 0.02;
  // A fit residual this large against the contrast is not a straight edge:
  // an occluder, a shadow, a second object on the edge.
  double max_relative_residual = 0.08;

  bool IsValid(std::string* why) const;
};

// Why an observation of a tag is not used. Each has a stable text
// (ToString: what report.json and the floor reference's sightings print);
// nothing matches that text. Declared in the order of their texts, so that a
// std::map keyed by them lists them as the texts sort.
enum class ObservationFlag {
  kDefocused,            // "defocused": blurred wider than the gate's fraction of a cell
  kDetectorUnavailable,  // "detector_unavailable": the tag family's detector could not be made
  kDuplicateId,          // "duplicate_id": a floor tag's id seen twice in a frame
  kEdgeNotStraight,      // "edge_not_straight": the fit's residual too large for a straight edge
  kEdgesNotFitted,       // "edges_not_fitted": the four edges could not be fitted at all
  kLowContrast,          // "low_contrast"
  kNotSeen,              // "not_seen": a floor tag in no frame
  kOverexposed,          // "overexposed": clipped pixels flatten one side of an edge
};
const char* ToString(ObservationFlag flag);
// The texts, in order (report.json's "flags").
using odocal::ToStrings;  // base/format.h: each flag's ToString

// Why `quality` fails `gate` (overexposed, low_contrast, defocused,
// edge_not_straight, in that order); empty when usable.
std::vector<ObservationFlag> QualityFlags(const TagImageQuality& quality, const QualityGate& gate = {});

struct ModelFreeRefineResult : CornerRefineResult {
  TagImageQuality quality;  // filled whenever the four edges could be fitted
};

ModelFreeRefineResult RefineTagCornersModelFree(const cv::Mat& grey,
                                                const std::array<cv::Point2d, 4>& corners_px,
                                                const CameraModel* camera,
                                                const CornerRefineOptions& options = {},
                                                const cv::Point& origin = {0, 0});

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_EDGE_QUALITY_H_
