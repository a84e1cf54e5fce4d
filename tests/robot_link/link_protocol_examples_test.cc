// The byte-level examples of docs/protocol.md, produced by the real code and
// pinned here: if the wire format changes, this test fails until the golden
// bytes (and the document) are updated together. Prints every example.
#include <cstdio>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "link_test_util.h"
#include "protocol_examples.h"
#include "odocal/robot_link/firmware_host.h"

namespace odocal::robot_link {
namespace {

class LinkProtocolExamples : public ::testing::Test {
 protected:
  LinkProtocolExamples() : link_(RobotOptions{}, backend_, &storage_) {}

  // Sends `request`, returns the raw bytes the robot answered.
  Bytes Exchange(const Frame& request) {
    const Bytes wire = EncodeFrame(request);
    Show("request " + Describe(request), wire);
    link_.Write(wire);
    return Drain();
  }
  Bytes Drain() {
    Bytes out;
    uint8_t buf[512];
    while (true) {
      const IoResult r = link_.Read(buf, std::chrono::milliseconds(0));
      if (r.status != IoStatus::kOk) break;
      out.insert(out.end(), buf, buf + r.bytes);
    }
    return out;
  }
  static std::string Describe(const Frame& f) {
    char s[64];
    std::snprintf(s, sizeof s, "type 0x%02x seq %u", f.type, f.seq);
    return s;
  }
  void Show(const std::string& name, const Bytes& bytes) {
    const std::string hex = ToHex(bytes);
    std::printf("[example] %s (%zu bytes)\n  %s\n", name.c_str(), bytes.size(), hex.c_str());
    auto it = Golden().find(name);
    if (it == Golden().end()) {
      ADD_FAILURE() << "no golden bytes for example '" << name << "'";
    } else {
      EXPECT_EQ(hex, it->second) << name;
    }
  }

  FakeMotionBackend backend_;
  MemoryStorage storage_;
  LoopbackTransport link_;
};

TEST_F(LinkProtocolExamples, WireFramesOfAPushAndARun) {
  for (const Example& e : PushConversation()) {
    const Bytes reply = Exchange(e.request);
    if (!e.reply_name.empty()) Show(e.reply_name, reply);
  }
  uint16_t seq = PushConversation().back().request.seq + 1;
  // First record ever: slot A, generation 1.
  Show("storage slot A after commit",
       Bytes(storage_.image().begin(), storage_.image().begin() + OLF_STORAGE_RECORD_SIZE));

  Show("reply TELEMETRY_RATE",
       Exchange(testing::Request(OLF_MSG_TELEMETRY_RATE, seq++, ByteWriter().U16(10).Take())));
  ByteWriter run;
  run.U8(OLF_PROC_STRAIGHT).U8(OLF_DIR_CCW).F64(200.0).U32(0);
  Show("reply RUN_START", Exchange(testing::Request(OLF_MSG_RUN_START, seq++, run.Take())));
  link_.robot().Tick(0.25);  // 100 mm at 400 mm/s
  Show("event TELEMETRY", Drain());
  link_.robot().Tick(0.25);  // the remaining 100 mm: done
  Show("event TELEMETRY + RUN_COMPLETE", Drain());
}

}  // namespace
}  // namespace odocal::robot_link
