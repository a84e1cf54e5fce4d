// LiveServerOptions::IsValid (rig/live/live_server.h): the defaults pass; a host name where an
// address belongs, a port out of range, a stream with no rate or no room fail, and `why` says which.
// LiveOptions' own test is in live_state_test.cc.
#include <limits>

#include <gtest/gtest.h>

#include "odocal/live/live_server.h"
#include "odocal/test_util/options_checks.h"

namespace odocal::live {
namespace {

using test_util::ExpectValidAndEachEditRejected;

TEST(LiveServerOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  for (const char* address : {"0.0.0.0", "::1", "::"}) {
    LiveServerOptions o;
    o.bind_address = address;
    std::string why;
    EXPECT_TRUE(o.IsValid(&why)) << address << ": " << why;
  }
  LiveServerOptions any_port;
  any_port.port = 0;
  EXPECT_TRUE(any_port.IsValid(nullptr)) << "0: any free port";
  ExpectValidAndEachEditRejected<LiveServerOptions>(
      {},
      {{[](LiveServerOptions* o) { o->bind_address = "localhost"; }, "bind address 'localhost'"},
       {[](LiveServerOptions* o) { o->bind_address = "127.0.0.256"; }, "127.0.0.256"},
       {[](LiveServerOptions* o) { o->port = -1; }, "port -1"},
       {[](LiveServerOptions* o) { o->port = 65536; }, "port 65536"},
       {[](LiveServerOptions* o) { o->stream_max_fps = 0.0; }, "stream_max_fps"},
       {[](LiveServerOptions* o) { o->stream_max_fps = std::numeric_limits<double>::quiet_NaN(); }, "stream_max_fps"},
       {[](LiveServerOptions* o) { o->max_streams = 0; }, "max_streams"}});
}

}  // namespace
}  // namespace odocal::live
