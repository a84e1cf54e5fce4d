#include "odocal/vision/image_formation.h"

#include <csetjmp>
#include <cstdio>
#include <cstdlib>

// jpeglib.h needs FILE and size_t declared before it. The MJPEG stage
// (JpegRoundTrip, image_formation.h).
#include <jpeglib.h>

namespace odocal::vision {
namespace {

// libjpeg's default error handler exits the process; this one jumps back.
struct ErrorManager {
  jpeg_error_mgr base;
  std::jmp_buf jump;
};

void OnError(j_common_ptr info) {
  (*info->err->output_message)(info);
  std::longjmp(reinterpret_cast<ErrorManager*>(info->err)->jump, 1);
}

// The coded bytes, or none. setjmp's caller keeps no object with a destructor
// alive across the jump: only libjpeg's own state and malloc'd memory.
bool Encode(const cv::Mat& grey, int quality, unsigned char** bytes, unsigned long* size) {
  jpeg_compress_struct info;
  ErrorManager error;
  info.err = jpeg_std_error(&error.base);
  error.base.error_exit = OnError;
  if (setjmp(error.jump)) {
    jpeg_destroy_compress(&info);
    return false;
  }
  jpeg_create_compress(&info);
  jpeg_mem_dest(&info, bytes, size);
  info.image_width = static_cast<JDIMENSION>(grey.cols);
  info.image_height = static_cast<JDIMENSION>(grey.rows);
  info.input_components = 1;
  info.in_color_space = JCS_GRAYSCALE;
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, quality, TRUE);
  jpeg_start_compress(&info, TRUE);
  while (info.next_scanline < info.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(grey.ptr<unsigned char>(static_cast<int>(info.next_scanline)));
    jpeg_write_scanlines(&info, &row, 1);
  }
  jpeg_finish_compress(&info);
  jpeg_destroy_compress(&info);
  return true;
}

bool Decode(const unsigned char* bytes, unsigned long size, cv::Mat* grey) {
  jpeg_decompress_struct info;
  ErrorManager error;
  info.err = jpeg_std_error(&error.base);
  error.base.error_exit = OnError;
  if (setjmp(error.jump)) {
    jpeg_destroy_decompress(&info);
    return false;
  }
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, bytes, size);
  jpeg_read_header(&info, TRUE);
  if (info.image_width != static_cast<JDIMENSION>(grey->cols) ||
      info.image_height != static_cast<JDIMENSION>(grey->rows)) {
    jpeg_destroy_decompress(&info);
    return false;
  }
  info.out_color_space = JCS_GRAYSCALE;
  jpeg_start_decompress(&info);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = grey->ptr<unsigned char>(static_cast<int>(info.output_scanline));
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  return true;
}

}  // namespace

cv::Mat JpegRoundTrip(const cv::Mat& grey, int quality) {
  CV_Assert(grey.type() == CV_8UC1 && !grey.empty());
  unsigned char* bytes = nullptr;
  unsigned long size = 0;
  cv::Mat out(grey.size(), CV_8UC1);
  const bool ok = Encode(grey, quality, &bytes, &size) && Decode(bytes, size, &out);
  std::free(bytes);
  return ok ? out : cv::Mat();
}

}  // namespace odocal::vision
