#include "odocal/media/image_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>

namespace odocal::media {

GreyImage ReadGreyImage(const std::string& path) {
  GreyImage out;
  cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
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

}  // namespace odocal::media
