// Live frames: the interface the station reads a camera through, and a real
// camera through OpenCV. The virtual camera (simulation::SimCameraSource)
// implements the same interface.
#ifndef ODOCAL_MEDIA_FRAME_SOURCE_H_
#define ODOCAL_MEDIA_FRAME_SOURCE_H_

#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "odocal/base/status.h"

namespace odocal::media {

namespace internal {
class VideoInput;
}  // namespace internal

// A camera frame as the station receives it: 8-bit grey, with its time.
struct CameraFrame {
  cv::Mat grey;
  double t_s = 0.0;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // The next frame; kIoError naming the camera when it delivers none
  // (unplugged, stream ended).
  virtual Result<CameraFrame> Grab() = 0;
  virtual std::string Describe() const = 0;
  // The frame rate the camera delivers at, when it says: frames further
  // apart than that were dropped (a machine too busy to take them).
  virtual std::optional<double> NominalFps() const { return std::nullopt; }
};

// A real camera through OpenCV: a device index ("0") or a stream URL / file.
// Frames are stamped with the host's steady clock.
class CaptureSource final : public FrameSource {
 public:
  // kOpenFailed naming the device when the camera cannot be opened (kNotFound
  // when OpenCV's codecs cannot be loaded). One that opens but delivers
  // nothing fails at the first Grab, which names it.
  static Result<std::unique_ptr<CaptureSource>> Open(const std::string& device);
  Result<CameraFrame> Grab() override;
  std::string Describe() const override { return "camera " + device_; }
  std::optional<double> NominalFps() const override;
  ~CaptureSource() override;

 private:
  explicit CaptureSource(std::string device);
  std::string device_;
  std::unique_ptr<internal::VideoInput> capture_;  // OpenCV's, through the codecs (src/codecs.h)
  std::chrono::steady_clock::time_point opened_at_;
};

}  // namespace odocal::media

#endif  // ODOCAL_MEDIA_FRAME_SOURCE_H_
