#include "odocal/media/frame_source.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "codecs.h"

namespace odocal::media {
namespace {

double Seconds(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

}  // namespace

CaptureSource::CaptureSource(std::string device) : device_(std::move(device)) {}
CaptureSource::~CaptureSource() = default;

Result<std::unique_ptr<CaptureSource>> CaptureSource::Open(const std::string& device) {
  using R = Result<std::unique_ptr<CaptureSource>>;
  std::unique_ptr<CaptureSource> source(new CaptureSource(device));
  const bool is_index = !device.empty() && std::all_of(device.begin(), device.end(),
                                                      [](unsigned char c) { return std::isdigit(c); });
  std::string why;
  const internal::Codecs* codecs = internal::LoadCodecs(&why);
  if (!codecs) return R::Error(StatusCode::kNotFound, "cannot open camera '" + device + "': " + why);
  source->capture_ = codecs->OpenCamera(is_index ? std::stoi(device) : -1, device);
  if (!source->capture_)
    return R::Error(StatusCode::kOpenFailed, "cannot open camera '" + device + "'" +
                                                 (is_index ? " (no such video device, or busy)"
                                                           : " (no such stream or file, or no backend reads it)"));
  source->opened_at_ = std::chrono::steady_clock::now();
  return R::Ok(std::move(source));
}

std::optional<double> CaptureSource::NominalFps() const {
  const double fps = capture_->Fps();
  if (fps > 0.0 && std::isfinite(fps)) return fps;
  return std::nullopt;
}

Result<CameraFrame> CaptureSource::Grab() {
  cv::Mat frame;
  if (!capture_->Read(&frame) || frame.empty())
    return Result<CameraFrame>::Error(StatusCode::kIoError,
                                      "camera '" + device_ + "' delivered no frame (unplugged, or the stream ended)");
  CameraFrame out;
  out.t_s = Seconds(std::chrono::steady_clock::now() - opened_at_);
  if (frame.channels() == 3) {
    cv::cvtColor(frame, out.grey, cv::COLOR_BGR2GRAY);
  } else if (frame.channels() == 4) {
    cv::cvtColor(frame, out.grey, cv::COLOR_BGRA2GRAY);
  } else {
    out.grey = frame;
  }
  if (out.grey.depth() != CV_8U) out.grey.convertTo(out.grey, CV_8U);
  return Result<CameraFrame>::Ok(std::move(out));
}

}  // namespace odocal::media
