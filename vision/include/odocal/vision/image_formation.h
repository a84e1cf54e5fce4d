// Image formation of a real camera, for the renderer: the
// parts of a camera that odocal's own edge model does not assume. Every part
// is optional and off by default, so a RenderOptions without them renders
// exactly what it did before (Gaussian blur, additive noise, 8 bits).
//
// Order, as in a camera: scene irradiance (tag print levels, light gradient,
// vignetting) -> optics (the PSF: Gaussian, defocus disk, or both) -> pixel
// area integration (renderer) -> rolling-shutter row timing (renderer) ->
// photo-electrons (Poisson, here its Gaussian limit, plus read noise; clipped
// at the full well) -> 12-bit raw, through a Bayer mosaic and OpenCV's
// demosaic when asked -> tone curve (gamma) -> sharpening -> 8 bits ->
// codec (MJPEG in-process per frame; H.264 is the video writer's, video.h).
//
// Units: scene levels in the renderer's grey levels (0..255 = black..full
// scale at unit gain, linear light); pixels in OpenCV's convention.
#ifndef ODOCAL_VISION_IMAGE_FORMATION_H_
#define ODOCAL_VISION_IMAGE_FORMATION_H_

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace odocal::vision {

// Point-spread function of the optics. "Equal width" between models means
// equal per-axis second moment: a uniform disk of radius r has r^2 / 4, so a
// disk of radius 2 sigma is as wide as a Gaussian of sigma (EquivalentSigma).
struct PsfOptions {
  enum class Model { kGaussian, kDisk, kDiskGaussian };
  Model model = Model::kGaussian;
  double radius_px = 0.0;  // defocus disk (kDisk, kDiskGaussian)
  double sigma_px = 0.8;   // Gaussian (kGaussian, kDiskGaussian)

  double EquivalentSigma() const;
  bool IsValid(std::string* why) const;
};
const char* ToString(PsfOptions::Model model);
std::optional<PsfOptions::Model> ParsePsfModel(const std::string& name);

// Poisson-Gaussian sensor noise: full scale (grey 255 at unit gain) is
// `full_well_e` electrons; shot noise sqrt(electrons), plus `read_e`.
struct SensorNoiseOptions {
  double read_e = 5.0;
  double full_well_e = 10000.0;
  bool IsValid(std::string* why) const;
};

struct CodecOptions {
  enum class Kind { kNone, kH264, kMjpeg };
  Kind kind = Kind::kNone;
  int crf = 23;      // H.264 (x264 CRF)
  int quality = 80;  // MJPEG (JPEG quality 1..100)
  bool IsValid(std::string* why) const;
};

struct ImageFormationOptions {
  std::optional<PsfOptions> psf;  // nullopt: RenderOptions::blur_sigma_px, Gaussian
  // Row read-out time over the whole frame; row v is exposed around
  // t_mid + (v / (H - 1) - 1/2) * rolling_shutter_s. 0 = global shutter.
  double rolling_shutter_s = 0.0;
  bool bayer = false;  // RGGB mosaic, bilinear demosaic (OpenCV), back to grey
  double gamma = 1.0;  // output = 255 (linear / 255)^(1 / gamma); 1 = linear
  // Irradiance lost at the image corner (1 - vignetting (r / r_corner)^2).
  double vignetting = 0.0;
  // Irradiance change from the left to the right image border, relative
  // (+0.2: the right border 20 % brighter than the left, linear in x).
  double light_gradient = 0.0;
  double gain = 1.0;  // exposure: > 1 drives the whites into the full well
  std::optional<SensorNoiseOptions> noise;  // nullopt: RenderOptions::noise_sigma, additive
  // Unsharp mask on the tone-mapped image (phones): out + amount (out - blur).
  double sharpen = 0.0;
  double sharpen_sigma_px = 1.0;
  CodecOptions codec;

  // Whether anything after the optics differs from the plain renderer.
  bool HasSensorChain() const;
  bool IsValid(std::string* why) const;
};

// The named presets: "machine-vision", "webcam", "phone".
std::optional<ImageFormationOptions> ImageFormationPreset(const std::string& name);
std::vector<std::string> ImageFormationPresetNames();

// Blurs `src` (CV_32F, sampled at `scale` x the image resolution) by the
// PSF, given in image pixels.
void ApplyPsf(const cv::Mat& src, cv::Mat* dst, const PsfOptions& psf, int scale);
// Half-size of the PSF's support in image pixels (for the renderer's margins).
int PsfMarginPx(const PsfOptions& psf);

// Relative illumination (vignetting x gradient) over a W x H image, CV_32F.
cv::Mat IlluminationField(const ImageFormationOptions& options, cv::Size size);

// Irradiance (CV_32F, grey levels at unit gain) -> the 8-bit frame the camera
// delivers. `unit_normals` is a pool of N(0, 1) deviates at least
// size.area() + offset long (the renderer's pool), `offset` chosen per frame.
// `fresh_noise_roi` (may be empty) gets fresh deviates from `rng` instead.
cv::Mat SensorToGrey(const cv::Mat& irradiance, const ImageFormationOptions& options,
                     double additive_sigma, const cv::Mat& illumination,
                     const std::vector<float>& unit_normals, size_t offset,
                     const cv::Rect& fresh_noise_roi, cv::RNG* rng);

// The MJPEG stage: an 8-bit grey frame (CV_8UC1) coded as a baseline JPEG at
// `quality` (1-100) and decoded again, in memory. libjpeg directly, as
// OpenCV's cv::imencode / cv::imdecode call it (the same library and
// settings: jpeg_set_defaults, jpeg_set_quality(q, baseline), the slow
// integer DCT both ways), so the frames are the same bit for bit
// (JpegRoundTrip.IsOpenCvsImencodeAndImdecode), without OpenCV's image
// codecs: they bring 140 shared libraries (GDAL, GDCM, OpenEXR, ...) into
// every process that links them, a fifth of a second at each start (media
// loads them when a file is first read or written: rig/media/src/codecs.h).
// An empty Mat when libjpeg reports an error (it says why on stderr).
cv::Mat JpegRoundTrip(const cv::Mat& grey, int quality);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_IMAGE_FORMATION_H_
