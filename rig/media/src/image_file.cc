#include "odocal/media/image_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "codecs.h"

namespace odocal::media {

GreyImage ReadGreyImage(const std::string& path) {
  GreyImage out;
  const internal::Codecs* codecs = internal::LoadCodecs(&out.error);
  if (!codecs) return out;
  cv::Mat image = codecs->ReadGreyAnyDepth(path);
  if (image.empty() || image.depth() == CV_8U) {
    out.grey = image;
    return out;
  }
  double min_value = 0.0, max_value = 0.0;
  cv::minMaxLoc(image, &min_value, &max_value);
  double scale = 1.0;
  char what[160];
  if (image.depth() == CV_16U || image.depth() == CV_16S) {
    int bits = 8;
    while (bits < 16 && max_value > std::ldexp(1.0, bits) - 1.0) ++bits;
    scale = 255.0 / (std::ldexp(1.0, bits) - 1.0);
    std::snprintf(what, sizeof(what), "16-bit file, values up to %.0f: read as %s %d-bit sensor", max_value,
                  bits == 8 || bits == 11 ? "an" : "a", bits);
  } else {
    scale = max_value <= 1.0 ? 255.0 : 255.0 / max_value;
    std::snprintf(what, sizeof(what), "floating-point file, values up to %.4g: scaled by %.4g", max_value, scale);
  }
  image.convertTo(out.grey, CV_8U, scale);
  out.conversion = what;
  return out;
}

Status WriteImage(const std::string& path, const cv::Mat& image) {
  std::string why;
  const internal::Codecs* codecs = internal::LoadCodecs(&why);
  if (!codecs) return Status::Error(StatusCode::kFailed, path + ": cannot write: " + why);
  if (!codecs->WriteImage(path, image))
    return Status::Error(StatusCode::kIoError,
                         path + ": cannot write (not writable, or no image format has that extension)");
  return Status::Ok();
}

namespace {

// An image coded by `code` (the codecs' PNG or JPEG): kFailed when the
// codecs cannot be loaded or the image cannot be coded.
template <typename Code>
Result<std::vector<unsigned char>> Encode(const char* format, const Code& code) {
  using Bytes = Result<std::vector<unsigned char>>;
  std::string why;
  const internal::Codecs* codecs = internal::LoadCodecs(&why);
  if (!codecs) return Bytes::Error(StatusCode::kFailed, why);
  std::vector<unsigned char> bytes;
  if (!code(*codecs, &bytes))
    return Bytes::Error(StatusCode::kFailed, std::string("the image cannot be coded as ") + format);
  return Bytes::Ok(std::move(bytes));
}

}  // namespace

Result<std::vector<unsigned char>> EncodePng(const cv::Mat& image) {
  return Encode(
      "PNG", [&](const internal::Codecs& c, std::vector<unsigned char>* bytes) { return c.EncodePng(image, bytes); });
}

Result<std::vector<unsigned char>> EncodeJpeg(const cv::Mat& image, int quality) {
  return Encode("JPEG", [&](const internal::Codecs& c, std::vector<unsigned char>* bytes) {
    return c.EncodeJpeg(image, quality, bytes);
  });
}

}  // namespace odocal::media
