// Helpers shared by the robot_link tests: raw request/reply exchanges that
// bypass the Client (to send what a correct client never would) and seeded
// random parameter sets.
#ifndef ODOCAL_TESTS_ROBOT_LINK_LINK_TEST_UTIL_H_
#define ODOCAL_TESTS_ROBOT_LINK_LINK_TEST_UTIL_H_

#include <poll.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <functional>
#include <optional>
#include <thread>
#include <random>
#include <vector>

#include "odocal/robot_link/codec.h"
#include "odocal/robot_link/params.h"
#include "odocal/robot_link/pty.h"
#include "odocal/robot_link/transport.h"
#include "odolink/olf_wire.h"

namespace odocal::robot_link::testing {

// Sends one frame and returns the first reply carrying `seq` (none if the
// transport has nothing to say within `timeout`).
inline std::optional<Frame> RawExchange(Transport& t, const Frame& request,
                                        std::chrono::milliseconds timeout =
                                            std::chrono::milliseconds(500)) {
  const Bytes wire = EncodeFrame(request);
  if (t.Write(wire).status != IoStatus::kOk) return std::nullopt;
  FrameDecoder decoder;
  std::array<uint8_t, 256> buf;
  while (true) {
    const IoResult r = t.Read(buf, timeout);
    if (r.status != IoStatus::kOk) return std::nullopt;
    for (size_t i = 0; i < r.bytes; ++i) {
      std::optional<Frame> f = decoder.Feed(buf[i]);
      if (f && f->type < OLF_MSG_TELEMETRY && f->seq == request.seq) return f;
    }
  }
}

inline Frame Request(uint8_t type, uint16_t seq, Bytes body = {},
                     uint8_t version = OLF_PROTOCOL_VERSION) {
  return Frame{version, type, seq, std::move(body)};
}

// A valid set drawn from wide but plausible ranges.
inline ParamSet RandomParamSet(std::mt19937& rng) {
  std::uniform_real_distribution<double> diameter(40.0, 120.0);
  std::uniform_real_distribution<double> track(150.0, 600.0);
  std::uniform_int_distribution<uint32_t> ticks(256, 65536);
  return ParamSet{diameter(rng), diameter(rng), track(rng), ticks(rng)};
}

// A peer on a pty that answers every request with `reply_for(request)`.
class FakePeer {
 public:
  explicit FakePeer(std::function<Bytes(const Frame&)> reply_for)
      : pty_(std::move(*OpenPty().value)), reply_for_(std::move(reply_for)),
        thread_([this] { Loop(); }) {}
  ~FakePeer() {
    stop_ = true;
    thread_.join();
  }
  const std::string& path() const { return pty_.slave_path; }

 private:
  void Loop() {
    FrameDecoder decoder;
    uint8_t buf[256];
    while (!stop_) {
      pollfd p{pty_.master.get(), POLLIN, 0};
      if (::poll(&p, 1, 5) <= 0) continue;
      const ssize_t n = ::read(pty_.master.get(), buf, sizeof buf);
      for (ssize_t i = 0; i < n; ++i) {
        if (std::optional<Frame> f = decoder.Feed(buf[i])) {
          const Bytes out = reply_for_(*f);
          if (::write(pty_.master.get(), out.data(), out.size()) < 0) return;
        }
      }
    }
  }
  Pty pty_;
  std::function<Bytes(const Frame&)> reply_for_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace odocal::robot_link::testing

#endif  // ODOCAL_TESTS_ROBOT_LINK_LINK_TEST_UTIL_H_
