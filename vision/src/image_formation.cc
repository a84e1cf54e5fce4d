#include "odocal/vision/image_formation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include <opencv2/imgproc.hpp>

#include "raster.h"

namespace odocal::vision {
namespace {

bool Fail(std::string* why, const char* msg) {
  if (why) *why = msg;
  return false;
}

// A colour sensor under a white (grey) scene: the green pixels collect the
// most light; red and blue less, by typical silicon + filter responses under
// ~5000 K light. The ISP's white balance divides them back out, so red and
// blue carry more relative noise and clip later -- what a grey tag shows.
constexpr double kBayerSensitivity[3] = {0.75, 1.0, 0.6};  // B, G, R (OpenCV order)

// Raw data are digitised at 12 bits, as most webcam and phone sensors do.
constexpr double kRawFullScale = 4095.0;

}  // namespace

double PsfOptions::EquivalentSigma() const {
  const double disk = model == Model::kGaussian ? 0.0 : radius_px * radius_px / 4.0;
  const double gauss = model == Model::kDisk ? 0.0 : sigma_px * sigma_px;
  return std::sqrt(disk + gauss);
}

bool PsfOptions::IsValid(std::string* why) const {
  if (model != Model::kGaussian && !(radius_px > 0.0 && radius_px <= 20.0))
    return Fail(why, "psf.radius_px must be in (0, 20] for a disk");
  if (model != Model::kDisk && !(sigma_px >= 0.0 && sigma_px <= 20.0))
    return Fail(why, "psf.sigma_px must be in [0, 20]");
  return true;
}

const char* ToString(PsfOptions::Model model) {
  switch (model) {
    case PsfOptions::Model::kGaussian: return "gaussian";
    case PsfOptions::Model::kDisk: return "disk";
    case PsfOptions::Model::kDiskGaussian: return "disk+gaussian";
  }
  return "?";
}

std::optional<PsfOptions::Model> ParsePsfModel(const std::string& name) {
  if (name == "gaussian") return PsfOptions::Model::kGaussian;
  if (name == "disk") return PsfOptions::Model::kDisk;
  if (name == "disk+gaussian") return PsfOptions::Model::kDiskGaussian;
  return std::nullopt;
}

bool SensorNoiseOptions::IsValid(std::string* why) const {
  if (!(read_e >= 0.0)) return Fail(why, "noise.read_e must be >= 0");
  if (!(full_well_e >= 100.0)) return Fail(why, "noise.full_well_e must be >= 100");
  return true;
}

bool CodecOptions::IsValid(std::string* why) const {
  if (crf < 0 || crf > 51) return Fail(why, "codec h264 crf must be 0 to 51");
  if (quality < 1 || quality > 100) return Fail(why, "codec mjpeg quality must be 1 to 100");
  return true;
}

bool ImageFormationOptions::HasSensorChain() const {
  return bayer || std::abs(gamma - 1.0) > 1e-12 || vignetting != 0.0 || light_gradient != 0.0 ||
         std::abs(gain - 1.0) > 1e-12 || noise.has_value() || sharpen != 0.0 ||
         codec.kind == CodecOptions::Kind::kMjpeg;
}

bool ImageFormationOptions::IsValid(std::string* why) const {
  if (psf && !psf->IsValid(why)) return false;
  if (!(rolling_shutter_s >= 0.0 && rolling_shutter_s <= 1.0))
    return Fail(why, "rolling_shutter_ms must be in [0, 1000]");
  if (!(gamma >= 0.2 && gamma <= 5.0)) return Fail(why, "gamma must be in [0.2, 5]");
  if (!(vignetting >= 0.0 && vignetting < 1.0)) return Fail(why, "vignetting must be in [0, 1)");
  if (!(std::abs(light_gradient) < 1.0)) return Fail(why, "light_gradient must be in (-1, 1)");
  if (!(gain > 0.0 && gain <= 20.0)) return Fail(why, "gain must be in (0, 20]");
  if (noise && !noise->IsValid(why)) return false;
  if (!(sharpen >= 0.0 && sharpen <= 5.0)) return Fail(why, "sharpen must be in [0, 5]");
  if (!(sharpen_sigma_px > 0.0 && sharpen_sigma_px <= 5.0))
    return Fail(why, "sharpen_sigma_px must be in (0, 5]");
  return codec.IsValid(why);
}

std::vector<std::string> ImageFormationPresetNames() { return {"machine-vision", "webcam", "phone"}; }

std::optional<ImageFormationOptions> ImageFormationPreset(const std::string& name) {
  ImageFormationOptions o;
  if (name == "machine-vision") {
    // A global-shutter mono industrial camera with a good lens in focus.
    o.psf = PsfOptions{PsfOptions::Model::kDiskGaussian, 0.6, 0.5};
    o.gamma = 1.0;
    o.vignetting = 0.1;
    o.light_gradient = 0.05;
    o.noise = SensorNoiseOptions{3.0, 20000.0};
    o.codec = {CodecOptions::Kind::kH264, 12, 95};
    return o;
  }
  if (name == "webcam") {
    // A 1080p USB webcam: small lens slightly out of focus, ~20 ms rolling
    // read-out, colour sensor, sRGB-like tone curve, small pixels (noisy).
    o.psf = PsfOptions{PsfOptions::Model::kDisk, 0.8, 0.0};
    o.rolling_shutter_s = 0.020;
    o.bayer = true;
    o.gamma = 2.2;
    o.vignetting = 0.3;
    o.light_gradient = 0.15;
    o.noise = SensorNoiseOptions{6.0, 4000.0};
    o.codec = {CodecOptions::Kind::kH264, 23, 80};
    return o;
  }
  if (name == "phone") {
    // A phone camera: rolling shutter, aggressive ISP sharpening, CRF 28.
    o.psf = PsfOptions{PsfOptions::Model::kDiskGaussian, 0.8, 0.4};
    o.rolling_shutter_s = 0.015;
    o.bayer = true;
    o.gamma = 2.2;
    o.vignetting = 0.25;
    o.light_gradient = 0.1;
    o.noise = SensorNoiseOptions{3.0, 6000.0};
    o.sharpen = 1.0;
    o.sharpen_sigma_px = 1.0;
    o.codec = {CodecOptions::Kind::kH264, 28, 80};
    return o;
  }
  return std::nullopt;
}

int PsfMarginPx(const PsfOptions& psf) {
  const double disk = psf.model == PsfOptions::Model::kGaussian ? 0.0 : psf.radius_px;
  const double gauss = psf.model == PsfOptions::Model::kDisk ? 0.0 : 4.0 * psf.sigma_px;
  return static_cast<int>(std::ceil(disk + gauss)) + 1;
}

void ApplyPsf(const cv::Mat& src, cv::Mat* dst, const PsfOptions& psf, int scale) {
  cv::Mat current = src;
  if (psf.model != PsfOptions::Model::kGaussian) {
    // The disk, area-integrated over each kernel cell (16 x 16 samples a
    // cell): a point-sampled disk of radius ~1.6 fine pixels would be a
    // visibly different (and not rotation-symmetric) kernel.
    const double r = psf.radius_px * scale;
    const int half = static_cast<int>(std::ceil(r + 0.5));
    cv::Mat kernel(2 * half + 1, 2 * half + 1, CV_32F, cv::Scalar(0));
    constexpr int kSub = 16;
    double total = 0.0;
    for (int j = -half; j <= half; ++j) {
      for (int i = -half; i <= half; ++i) {
        int inside = 0;
        for (int b = 0; b < kSub; ++b) {
          for (int a = 0; a < kSub; ++a) {
            const double x = i - 0.5 + (a + 0.5) / kSub, y = j - 0.5 + (b + 0.5) / kSub;
            inside += x * x + y * y <= r * r ? 1 : 0;
          }
        }
        kernel.at<float>(j + half, i + half) = static_cast<float>(inside);
        total += inside;
      }
    }
    kernel /= total;
    cv::Mat out;
    cv::filter2D(current, out, -1, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REPLICATE);
    current = out;
  }
  if (psf.model != PsfOptions::Model::kDisk && psf.sigma_px > 0.0) {
    cv::Mat out;
    internal::OpticalBlur(current, &out, psf.sigma_px * scale);
    current = out;
  }
  if (current.data == src.data) {
    src.copyTo(*dst);
  } else {
    *dst = current;
  }
}

cv::Mat IlluminationField(const ImageFormationOptions& options, cv::Size size) {
  cv::Mat field(size, CV_32F);
  const double cx = 0.5 * (size.width - 1), cy = 0.5 * (size.height - 1);
  const double r_corner2 = cx * cx + cy * cy;
  for (int v = 0; v < size.height; ++v) {
    float* row = field.ptr<float>(v);
    for (int u = 0; u < size.width; ++u) {
      const double r2 = ((u - cx) * (u - cx) + (v - cy) * (v - cy)) / r_corner2;
      const double gradient = 1.0 + options.light_gradient * ((u - cx) / std::max(1.0, 2.0 * cx));
      row[u] = static_cast<float>(options.gain * (1.0 - options.vignetting * r2) * gradient);
    }
  }
  return field;
}

namespace {

// The frame's unit normal deviates: the pool's from `offset`, fresh ones
// drawn over `fresh_noise_roi`.
cv::Mat UnitDeviates(const std::vector<float>& unit_normals, size_t offset, cv::Size size,
                     const cv::Rect& fresh_noise_roi, cv::RNG* rng) {
  const int W = size.width, H = size.height;
  cv::Mat normals(H, W, CV_32F);
  for (int v = 0; v < H; ++v) {
    const float* pool = unit_normals.data() + offset + static_cast<size_t>(v) * W;
    std::copy(pool, pool + W, normals.ptr<float>(v));
  }
  if (fresh_noise_roi.area() > 0) {
    cv::Mat roi = normals(fresh_noise_roi);
    rng->fill(roi, cv::RNG::NORMAL, 0.0, 1.0);
  }
  return normals;
}

// Raw: per-pixel channel sensitivity (Bayer), electrons, noise, clip, 12 bits
// (CV_16U).
cv::Mat ExposeRaw(const cv::Mat& irradiance, const cv::Mat& illumination, const cv::Mat& normals,
                  const ImageFormationOptions& options, double additive_sigma) {
  const int W = irradiance.cols, H = irradiance.rows;
  const double e_per_grey = options.noise ? options.noise->full_well_e / 255.0 : 0.0;
  const double read2 = options.noise ? options.noise->read_e * options.noise->read_e : 0.0;
  cv::Mat raw(H, W, CV_16U);
  for (int v = 0; v < H; ++v) {
    const float* irr = irradiance.ptr<float>(v);
    const float* light = illumination.ptr<float>(v);
    const float* z = normals.ptr<float>(v);
    uint16_t* out = raw.ptr<uint16_t>(v);
    for (int u = 0; u < W; ++u) {
      // RGGB: R at (even row, even col), B at (odd, odd), G elsewhere.
      const int channel = !options.bayer ? 1 : (v % 2 == 0 ? (u % 2 == 0 ? 2 : 1) : (u % 2 == 0 ? 1 : 0));
      double grey = irr[u] * light[u] * kBayerSensitivity[channel];
      if (options.noise) {
        const double electrons = std::max(0.0, grey * e_per_grey);
        grey += z[u] * std::sqrt(electrons + read2) / e_per_grey;
      } else {
        grey += z[u] * additive_sigma;
      }
      out[u] = static_cast<uint16_t>(std::clamp(std::lround(grey / 255.0 * kRawFullScale), 0L,
                                                static_cast<long>(kRawFullScale)));
    }
  }
  return raw;
}

// The raw frame as linear grey levels 0..255 (CV_32F): demosaiced, white
// balanced and turned to luma when the sensor has a Bayer filter.
cv::Mat RawToLinear(const cv::Mat& raw, bool bayer) {
  cv::Mat linear;
  if (bayer) {
    // OpenCV names Bayer patterns by the second row's 2nd and 3rd pixels:
    // RGGB (R at (0, 0)) is its BayerBG.
    cv::Mat bgr;
    cv::demosaicing(raw, bgr, cv::COLOR_BayerBG2BGR);
    std::vector<cv::Mat> ch;
    cv::split(bgr, ch);
    // White balance, then luma (BT.601 weights, as OpenCV's BGR2GRAY).
    constexpr double kLuma[3] = {0.114, 0.587, 0.299};
    linear = cv::Mat::zeros(raw.rows, raw.cols, CV_32F);
    for (int c = 0; c < 3; ++c) {
      cv::Mat f;
      ch[c].convertTo(f, CV_32F, 255.0 / kRawFullScale * kLuma[c] / kBayerSensitivity[c]);
      linear += f;
    }
  } else {
    raw.convertTo(linear, CV_32F, 255.0 / kRawFullScale);
  }
  return linear;
}

// Tone curve by a look-up on the 12-bit code values (as an ISP does).
void ApplyToneCurve(double gamma, cv::Mat* linear) {
  std::vector<float> lut(4096 * 2);  // white balance can push red/blue over full scale
  for (size_t k = 0; k < lut.size(); ++k)
    lut[k] = static_cast<float>(255.0 * std::pow(std::min(1.0, k / kRawFullScale), 1.0 / gamma));
  for (int v = 0; v < linear->rows; ++v) {
    float* row = linear->ptr<float>(v);
    for (int u = 0; u < linear->cols; ++u) {
      const double code = std::clamp(row[u] / 255.0 * kRawFullScale, 0.0, lut.size() - 2.0);
      const size_t k = static_cast<size_t>(code);
      const double f = code - k;
      row[u] = static_cast<float>(lut[k] * (1 - f) + lut[k + 1] * f);
    }
  }
}

}  // namespace

cv::Mat SensorToGrey(const cv::Mat& irradiance, const ImageFormationOptions& options, double additive_sigma,
                     const cv::Mat& illumination, const std::vector<float>& unit_normals, size_t offset,
                     const cv::Rect& fresh_noise_roi, cv::RNG* rng) {
  const cv::Mat normals = UnitDeviates(unit_normals, offset, irradiance.size(), fresh_noise_roi, rng);
  const cv::Mat raw = ExposeRaw(irradiance, illumination, normals, options, additive_sigma);
  cv::Mat linear = RawToLinear(raw, options.bayer);  // CV_32F, grey levels 0..255
  if (std::abs(options.gamma - 1.0) > 1e-12) ApplyToneCurve(options.gamma, &linear);
  if (options.sharpen > 0.0) {
    cv::Mat soft;
    cv::GaussianBlur(linear, soft, cv::Size(0, 0), options.sharpen_sigma_px);
    linear = linear + options.sharpen * (linear - soft);
  }
  cv::Mat grey;
  linear.convertTo(grey, CV_8U);  // rounds and saturates
  if (options.codec.kind == CodecOptions::Kind::kMjpeg) {
    grey = JpegRoundTrip(grey, options.codec.quality);
  }
  return grey;
}

}  // namespace odocal::vision
