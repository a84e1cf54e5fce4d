// Image files as the detectors read them: 8-bit grey, whatever the file
// holds. Machine-vision cameras and data sets store 10- and 12-bit sensors
// in 16-bit PNG and TIFF (values up to 1023 or 4095), which OpenCV's 8-bit
// conversion keeps only the top byte of (a frame of values 0-15): such a
// file is scaled by its sensor's full scale instead.
#ifndef ODOCAL_MEDIA_IMAGE_FILE_H_
#define ODOCAL_MEDIA_IMAGE_FILE_H_

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/status.h"

namespace odocal::media {

struct GreyImage {
  cv::Mat grey;  // CV_8UC1; empty when the file cannot be read as an image
  // Why not, when that is not the file's fault (the codecs could not be
  // loaded: src/codecs.h); empty otherwise.
  std::string error;
  // How a deeper image was brought to 8 bits ("16-bit file, values up to
  // 4095: read as a 12-bit sensor"); empty for an 8-bit file.
  std::string conversion;
};

// Colour is converted to grey (OpenCV's weights). A 16-bit image is scaled
// linearly by 255 / (2^bits - 1), bits the fewest (8 to 16) that hold its
// largest value, so a 12-bit sensor's full scale maps to 255 and the tone
// stays linear; a floating-point image by 255 when its values lie in [0, 1],
// else by its largest value.
GreyImage ReadGreyImage(const std::string& path);

// An 8-bit grey or BGR image as the format its extension names (.png, .jpg,
// ...); an error naming the file when it cannot be written.
Status WriteImage(const std::string& path, const cv::Mat& image);

// The bytes of a PNG, or a JPEG at `quality` (1-100), of an 8-bit grey or
// BGR image; kFailed saying why when it cannot be coded (or the codecs
// cannot be loaded).
Result<std::vector<unsigned char>> EncodePng(const cv::Mat& image);
Result<std::vector<unsigned char>> EncodeJpeg(const cv::Mat& image, int quality);

}  // namespace odocal::media

#endif  // ODOCAL_MEDIA_IMAGE_FILE_H_
