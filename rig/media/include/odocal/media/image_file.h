// Image files as the detectors read them: 8-bit grey, whatever the file
// holds. Machine-vision cameras and data sets store 10- and 12-bit sensors
// in 16-bit PNG and TIFF (values up to 1023 or 4095), which OpenCV's 8-bit
// conversion keeps only the top byte of (a frame of values 0-15): such a
// file is scaled by its sensor's full scale instead.
#ifndef ODOCAL_MEDIA_IMAGE_FILE_H_
#define ODOCAL_MEDIA_IMAGE_FILE_H_

#include <string>

#include <opencv2/core.hpp>

namespace odocal::media {

struct GreyImage {
  cv::Mat grey;  // CV_8UC1; empty when the file cannot be read as an image
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

}  // namespace odocal::media

#endif  // ODOCAL_MEDIA_IMAGE_FILE_H_
