// OpenCV's image and video codecs, loaded when media first needs them.
//
// libopencv_imgcodecs and libopencv_videoio bring 240 shared libraries with
// them (FFmpeg, GStreamer, GDAL, GDCM, OpenEXR, ...): linked into the binary,
// they cost every start of odocal a fifth to a third of a second of CPU in
// the dynamic loader, whether the command reads an image or not (`odocal
// --version` 0.30 s; without them 0.02 s, docs/performance.md). They live in
// a plugin instead, libodocal_media_codecs.so beside the binary
// (codecs_plugin/codecs_plugin.cc, nothing in it but the calls into OpenCV),
// which media opens on first use. Only media includes this header.
#ifndef ODOCAL_MEDIA_SRC_CODECS_H_
#define ODOCAL_MEDIA_SRC_CODECS_H_

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace odocal::media::internal {

// cv::VideoCapture, as media reads it.
class VideoInput {
 public:
  virtual ~VideoInput() = default;
  virtual bool Read(cv::Mat* frame) = 0;  // as decoded (BGR, or grey)
  virtual double Fps() const = 0;         // 0 when the container does not say
  virtual double FrameCount() const = 0;  // as the container claims; may be -1
};

// cv::VideoWriter through FFmpeg, H.264 (avc1) of BGR frames.
class VideoOutput {
 public:
  virtual ~VideoOutput() = default;
  virtual void Write(const cv::Mat& bgr) = 0;
};

class Codecs {
 public:
  virtual ~Codecs() = default;
  // cv::imread(path, IMREAD_GRAYSCALE | IMREAD_ANYDEPTH): empty when unreadable.
  virtual cv::Mat ReadGreyAnyDepth(const std::string& path) const = 0;
  // cv::imwrite: false when it could not.
  virtual bool WriteImage(const std::string& path, const cv::Mat& image) const = 0;
  // cv::imencode(".png") / (".jpg" at `jpeg_quality`): false when it could not.
  virtual bool EncodePng(const cv::Mat& image, std::vector<unsigned char>* bytes) const = 0;
  virtual bool EncodeJpeg(const cv::Mat& image, int jpeg_quality, std::vector<unsigned char>* bytes) const = 0;
  // A file through FFmpeg; nullptr when it does not open.
  virtual std::unique_ptr<VideoInput> OpenVideoFile(const std::string& path) const = 0;
  // A camera: a device index (>= 0), else a stream URL or file (OpenCV's
  // default backends); nullptr when it does not open.
  virtual std::unique_ptr<VideoInput> OpenCamera(int index, const std::string& url) const = 0;
  // nullptr when H.264 cannot be written there.
  virtual std::unique_ptr<VideoOutput> OpenH264File(const std::string& path, double fps, cv::Size size) const = 0;
};

// The codecs, the plugin opened once (thread-safe). nullptr with `*error`
// ("the image and video codecs cannot be loaded (PATH: why; ...)") when it
// cannot be: looked for at $ODOCAL_CODECS_PLUGIN alone when that is set, else
// beside the running binary, then where this build put it.
const Codecs* LoadCodecs(std::string* error);

}  // namespace odocal::media::internal

// The plugin's one symbol (C linkage, so that dlsym finds it by this name).
extern "C" const odocal::media::internal::Codecs* odocal_media_codecs_v1();

#endif  // ODOCAL_MEDIA_SRC_CODECS_H_
