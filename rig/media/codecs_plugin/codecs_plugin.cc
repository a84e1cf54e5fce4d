// libodocal_media_codecs.so: OpenCV's image and video codecs behind media's
// Codecs interface (rig/media/src/codecs.h, which says why this is a plugin).
// Nothing else belongs here: every decision about images and video is media's.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "codecs.h"

namespace odocal::media::internal {
namespace {

class CaptureInput final : public VideoInput {
 public:
  bool Read(cv::Mat* frame) override { return capture.read(*frame); }
  double Fps() const override { return capture.get(cv::CAP_PROP_FPS); }
  double FrameCount() const override { return capture.get(cv::CAP_PROP_FRAME_COUNT); }
  cv::VideoCapture capture;
};

class WriterOutput final : public VideoOutput {
 public:
  void Write(const cv::Mat& bgr) override { writer.write(bgr); }
  cv::VideoWriter writer;
};

class OpenCvCodecs final : public Codecs {
 public:
  cv::Mat ReadGreyAnyDepth(const std::string& path) const override {
    return cv::imread(path, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
  }
  bool WriteImage(const std::string& path, const cv::Mat& image) const override {
    try {
      return cv::imwrite(path, image);
    } catch (const cv::Exception&) {
      return false;  // e.g. no encoder for the file's extension
    }
  }
  bool EncodePng(const cv::Mat& image, std::vector<unsigned char>* bytes) const override {
    return cv::imencode(".png", image, *bytes);
  }
  bool EncodeJpeg(const cv::Mat& image, int jpeg_quality, std::vector<unsigned char>* bytes) const override {
    return cv::imencode(".jpg", image, *bytes, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
  }
  std::unique_ptr<VideoInput> OpenVideoFile(const std::string& path) const override {
    auto input = std::make_unique<CaptureInput>();
    if (!input->capture.open(path, cv::CAP_FFMPEG)) return nullptr;
    return input;
  }
  std::unique_ptr<VideoInput> OpenCamera(int index, const std::string& url) const override {
    auto input = std::make_unique<CaptureInput>();
    const bool opened = index >= 0 ? input->capture.open(index) : input->capture.open(url);
    if (!opened || !input->capture.isOpened()) return nullptr;
    return input;
  }
  std::unique_ptr<VideoOutput> OpenH264File(const std::string& path, double fps, cv::Size size) const override {
    auto output = std::make_unique<WriterOutput>();
    if (!output->writer.open(path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), fps, size, true))
      return nullptr;
    return output;
  }
};

}  // namespace
}  // namespace odocal::media::internal

extern "C" __attribute__((visibility("default"))) const odocal::media::internal::Codecs* odocal_media_codecs_v1() {
  static const odocal::media::internal::OpenCvCodecs codecs;
  return &codecs;
}
