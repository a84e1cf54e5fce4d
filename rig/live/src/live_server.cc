#include "odocal/live/live_server.h"

#include <arpa/inet.h>
#include <sys/socket.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <thread>

#include <httplib.h>

namespace odocal::live {
namespace {

using Clock = std::chrono::steady_clock;

constexpr const char* kBoundary = "odocal-frame";

bool IsNumericAddress(const std::string& address) {
  unsigned char buf[sizeof(struct in6_addr)];
  return inet_pton(AF_INET, address.c_str(), buf) == 1 || inet_pton(AF_INET6, address.c_str(), buf) == 1;
}

std::string HostPort(const std::string& address, int port) {
  const bool v6 = address.find(':') != std::string::npos;
  return (v6 ? "[" + address + "]" : address) + ":" + std::to_string(port);
}

std::string BindError(const std::string& address, int port, int error) {
  const std::string where = HostPort(address, port);
  switch (error) {
    case EADDRINUSE:
      return where + " is in use by another program (another odocal?): choose another port, or 0 for any free one";
    case EACCES:
      return where + ": permission denied (ports below 1024 need root)";
    case EADDRNOTAVAIL:
      return where + ": " + address + " is not an address of this machine";
    default:
      return "cannot listen on " + where + (error != 0 ? std::string(": ") + std::strerror(error) : "");
  }
}

}  // namespace

bool LiveServerOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (!IsNumericAddress(bind_address))
    return fail("bind address '" + bind_address + "' is not an IPv4 or IPv6 address (e.g. 127.0.0.1, 0.0.0.0)");
  if (port < 0 || port > 65535) return fail("port " + std::to_string(port) + " is not in 0..65535");
  if (!(stream_max_fps > 0.0)) return fail("stream_max_fps must be positive");
  if (max_streams < 1) return fail("max_streams must be at least 1");
  return true;
}

struct LiveServer::Impl {
  Impl(const LiveState& s, const LiveServerOptions& o) : state(s), options(o) {}
  const LiveState& state;
  const LiveServerOptions options;
  httplib::Server server;
  std::thread thread;
  std::atomic<bool> stopping{false};
  std::atomic<int> streams{0};

  void Routes();
  void ServeStream(httplib::Response& res);
};

void LiveServer::Impl::Routes() {
  const httplib::Headers no_store = {{"Cache-Control", "no-store"}};
  server.set_default_headers(no_store);
  server.Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_content(LivePageHtml(), "text/html; charset=utf-8");
  });
  server.Get("/state.json", [this](const httplib::Request&, httplib::Response& res) {
    // Labels come from file names and producers: never let a stray byte throw.
    res.set_content(state.StateJson().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace),
                    "application/json");
  });
  server.Get("/frame.jpg", [this](const httplib::Request&, httplib::Response& res) {
    const std::optional<LiveJpeg> jpeg = state.FrameJpeg();
    if (!jpeg) {
      res.status = 503;
      res.set_content("no frame yet\n", "text/plain");
      return;
    }
    res.set_header("X-Frame-Seq", std::to_string(jpeg->seq));
    res.set_content(reinterpret_cast<const char*>(jpeg->bytes->data()), jpeg->bytes->size(), "image/jpeg");
  });
  server.Get("/stream.mjpg", [this](const httplib::Request&, httplib::Response& res) { ServeStream(res); });
}

// One part per new frame, no faster than stream_max_fps; the connection's
// worker thread stays here until the client leaves or the server stops.
void LiveServer::Impl::ServeStream(httplib::Response& res) {
  if (streams.fetch_add(1) >= options.max_streams) {
    streams.fetch_sub(1);
    res.status = 503;
    res.set_content("too many streams open (" + std::to_string(options.max_streams) + ")\n", "text/plain");
    return;
  }
  struct Cursor {
    int64_t last_seq = 0;
    Clock::time_point next_due = Clock::now();
  };
  auto cursor = std::make_shared<Cursor>();
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options.stream_max_fps));
  res.set_chunked_content_provider(
      std::string("multipart/x-mixed-replace; boundary=") + kBoundary,
      [this, cursor, period](size_t, httplib::DataSink& sink) {
        constexpr auto kSlice = std::chrono::milliseconds(100);
        while (!stopping && Clock::now() < cursor->next_due)
          std::this_thread::sleep_for(std::min<Clock::duration>(kSlice, cursor->next_due - Clock::now()));
        while (!stopping && !state.WaitForFrame(cursor->last_seq, kSlice))
          if (!sink.is_writable()) return false;
        if (stopping) return false;
        const std::optional<LiveJpeg> jpeg = state.FrameJpeg();
        if (!jpeg) return false;
        std::string part = std::string("--") + kBoundary + "\r\nContent-Type: image/jpeg\r\nContent-Length: " +
                           std::to_string(jpeg->bytes->size()) + "\r\n\r\n";
        part.append(reinterpret_cast<const char*>(jpeg->bytes->data()), jpeg->bytes->size());
        part += "\r\n";
        if (!sink.write(part.data(), part.size())) return false;
        cursor->last_seq = jpeg->seq;
        cursor->next_due = Clock::now() + period;
        return true;
      },
      [this](bool) { streams.fetch_sub(1); });
}

Result<std::unique_ptr<LiveServer>> LiveServer::Start(const LiveState& state, const LiveServerOptions& options) {
  using R = Result<std::unique_ptr<LiveServer>>;
  std::string why;
  if (!options.IsValid(&why)) return R::Error(StatusCode::kInvalidArgument, why);
  auto impl = std::make_unique<Impl>(state, options);
  // httplib's default sets SO_REUSEPORT, with which a second server binds a
  // port already in use and the two share its connections. SO_REUSEADDR
  // only lets a restarted server reuse a port still in TIME_WAIT.
  impl->server.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  // Short enough that Stop() does not wait long for idle connections.
  impl->server.set_keep_alive_timeout(1);
  impl->server.set_read_timeout(2, 0);
  impl->server.set_write_timeout(5, 0);
  impl->Routes();
  errno = 0;
  int port = options.port;
  if (options.port == 0) {
    port = impl->server.bind_to_any_port(options.bind_address);
    if (port <= 0) return R::Error(StatusCode::kOpenFailed, BindError(options.bind_address, 0, errno));
  } else if (!impl->server.bind_to_port(options.bind_address, options.port)) {
    return R::Error(StatusCode::kOpenFailed, BindError(options.bind_address, options.port, errno));
  }
  httplib::Server* server = &impl->server;
  impl->thread = std::thread([server] { server->listen_after_bind(); });
  // Stop() can only end a server that runs: wait for it to start.
  const Clock::time_point give_up = Clock::now() + std::chrono::seconds(5);
  while (!server->is_running() && Clock::now() < give_up) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  if (!server->is_running()) {
    impl->thread.join();
    return R::Error(StatusCode::kOpenFailed, "cannot listen on " + HostPort(options.bind_address, port));
  }
  return R::Ok(std::unique_ptr<LiveServer>(new LiveServer(std::move(impl), port)));
}

LiveServer::LiveServer(std::unique_ptr<Impl> impl, int port) : impl_(std::move(impl)), port_(port) {}

LiveServer::~LiveServer() { Stop(); }

void LiveServer::Stop() {
  if (!impl_ || impl_->stopping.exchange(true)) return;
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

std::string LiveServer::url() const { return "http://" + HostPort(impl_->options.bind_address, port_) + "/"; }

}  // namespace odocal::live
