// The live view's web server (issue 13 §4): a LiveState served over HTTP on
// a background thread, for a browser next to the robot (a phone on the same
// network when bound to 0.0.0.0, the station's own screen on 127.0.0.1).
//
//   GET /             the page: one self-contained HTML file (no external
//                     fetches), laid out for a desktop or a phone
//   GET /state.json   LiveState::StateJson() (keys: docs/formats.md, "Live view")
//   GET /frame.jpg    the latest frame with the tag's outline (503 before the first)
//   GET /stream.mjpg  the same frames as multipart/x-mixed-replace (MJPEG), at
//                     most `stream_max_fps` a second, for `max_streams`
//                     clients at once (503 beyond)
//
// The page polls /state.json and loads /frame.jpg when the frame number
// changes; `/?mjpeg=1` shows /stream.mjpg instead. cpp-httplib (Debian's
// libcpp-httplib-dev) does the HTTP; it stays out of this header.
#ifndef ODOCAL_LIVE_LIVE_SERVER_H_
#define ODOCAL_LIVE_LIVE_SERVER_H_

#include <memory>
#include <string>

#include "odocal/base/status.h"
#include "odocal/live/live_state.h"

namespace odocal::live {

struct LiveServerOptions {
  // 127.0.0.1: this machine only; 0.0.0.0: every interface (a phone on the LAN).
  std::string bind_address = "127.0.0.1";
  // 0: any free port (LiveServer::port() says which).
  int port = 8080;
  double stream_max_fps = 15.0;
  int max_streams = 4;

  bool IsValid(std::string* why) const;
};

class LiveServer {
 public:
  // Binds and starts serving `state`, which must outlive the server.
  // kInvalidArgument for bad options; kOpenFailed when the address cannot be
  // bound ("127.0.0.1:8080 is in use by another program").
  static Result<std::unique_ptr<LiveServer>> Start(const LiveState& state, const LiveServerOptions& options);
  // Stop()s.
  ~LiveServer();
  LiveServer(const LiveServer&) = delete;
  LiveServer& operator=(const LiveServer&) = delete;

  // Closes the port, ends open streams and joins the server's threads
  // (within ~2 s: an idle keep-alive connection is dropped after 1 s, a
  // silent client after 2 s). Idempotent.
  void Stop();
  // The port bound (the real one when options.port was 0).
  int port() const { return port_; }
  // "http://ADDRESS:PORT/".
  std::string url() const;

 private:
  struct Impl;
  explicit LiveServer(std::unique_ptr<Impl> impl, int port);
  std::unique_ptr<Impl> impl_;
  int port_ = 0;
};

// The page GET / serves (exposed for tests and for saving it to a file).
const std::string& LivePageHtml();

}  // namespace odocal::live

#endif  // ODOCAL_LIVE_LIVE_SERVER_H_
