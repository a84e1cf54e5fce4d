// The byte-level examples of docs/protocol.md, produced by the real code and
// pinned here: if the wire format changes, this test fails until the golden
// bytes (and the document) are updated together. Prints every example.
#include <cstdio>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "link_test_util.h"
#include "odocal/robot_link/firmware_host.h"

namespace odocal::robot_link {
namespace {

// Golden hex, copied into docs/protocol.md.
const std::map<std::string, std::string>& Golden() {
  static const std::map<std::string, std::string> kGolden = {
      {"request type 0x01 seq 1",
       "00 04 01 01 01 01 03 fa d9 00"},
      {"reply HELLO",
       "00 04 01 40 01 0d 1b 01 01 04 60 16 e9 34 6a 54 c7 0e 12 0e 6f 64 6f 63 61 6c 2d 76 69 72 74 75 61 6c 19 29 00"},
      {"request type 0x05 seq 2",
       "00 04 01 05 02 01 03 69 78 00"},
      {"reply STAGE_BEGIN",
       "00 04 01 40 02 05 01 05 d4 24 00"},
      {"request type 0x06 seq 3",
       "00 04 01 06 03 1a 20 16 6c 65 66 74 5f 77 68 65 65 6c 5f 64 69 61 6d 65 74 65 72 5f 6d 6d 01 01 01 01 01 06 08 52 40 4c e7 00"},
      {"request type 0x06 seq 4",
       "00 04 01 06 04 1b 21 17 72 69 67 68 74 5f 77 68 65 65 6c 5f 64 69 61 6d 65 74 65 72 5f 6d 6d 01 01 01 01 01 06 f8 51 40 02 c8 00"},
      {"request type 0x06 seq 5",
       "00 04 01 06 05 0c 12 08 74 72 61 63 6b 5f 6d 6d 01 01 01 01 01 06 c4 70 40 8f 10 00"},
      {"reply STAGE_PUT",
       "00 04 01 40 05 05 01 06 b5 6a 00"},
      {"request type 0x06 seq 6",
       "00 04 01 06 06 13 13 0d 74 69 63 6b 73 5f 70 65 72 5f 72 65 76 02 a0 0f 01 03 ee ee 00"},
      {"request type 0x07 seq 7",
       "00 04 01 07 07 05 01 01 5e 59 00"},
      {"reply PARAMS_READ staged",
       "00 04 01 40 07 05 2b 07 01 0f 01 01 07 c0 34 ae 94 04 01 01 01 01 01 05 08 52 40 01 01 01 01 01 05 f8 51 40 01 01 01 01 01 07 c4 70 40 02 a0 0f 01 03 0f 5a 00"},
      {"request type 0x08 seq 8",
       "00 04 01 08 08 08 04 ef be ad de 03 4b 00"},
      {"reply COMMIT wrong checksum",
       "00 04 01 41 08 06 02 08 08 02 f3 00"},
      {"request type 0x08 seq 9",
       "00 04 01 08 09 08 04 c0 34 ae 94 18 cc 00"},
      {"reply COMMIT",
       "00 04 01 40 09 09 05 08 c0 34 ae 94 9e 0d 00"},
      {"reply COMMIT retry (from cache)",
       "00 04 01 40 09 09 05 08 c0 34 ae 94 9e 0d 00"},
      {"request type 0x01 seq 10",
       "00 04 02 01 0a 01 03 e4 fa 00"},
      {"reply HELLO version 2",
       "00 04 01 41 0a 07 03 01 01 01 1a 9e 00"},
      {"storage slot A after commit",
       "4f 44 4f 50 01 00 00 00 01 01 00 00 00 00 00 08 52 40 00 00 00 00 00 f8 51 40 00 00 00 00 00 c4 70 40 a0 0f 00 00 00 00 00 00 00 00 52 40 00 00 00 00 00 00 52 40 00 00 00 00 00 e0 70 40 00 10 00 00 5d d3 8a d1"},
      {"request type 0x0c seq 11",
       "00 04 01 0c 0b 03 02 0a 03 2f 18 00"},
      {"reply TELEMETRY_RATE",
       "00 04 01 40 0b 05 01 0c b6 7a 00"},
      {"request type 0x0a seq 12",
       "00 04 01 0a 0c 04 0e 02 01 01 01 01 01 01 03 69 40 01 01 01 03 ec d7 00"},
      {"reply RUN_START",
       "00 04 01 40 0c 04 03 0a 01 03 cf ce 00"},
      {"event TELEMETRY",
       "00 04 01 80 01 03 27 fa 01 01 03 e5 06 01 03 eb 06 01 01 01 01 01 01 01 03 59 40 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 03 01 01 03 dd 83 00"},
      {"event TELEMETRY + RUN_COMPLETE",
       "00 04 01 80 02 04 27 f4 01 01 03 cb 0d 01 03 d7 0d 01 01 01 01 01 01 01 03 69 40 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 03 01 01 03 b4 76 00 00 04 01 81 03 03 27 01 01 03 f4 01 01 03 cb 0d 01 03 d7 0d 01 01 01 01 01 01 01 03 69 40 01 01 01 01 01 01 01 01 01 01 01 01 01 01 01 03 5f af 00"},
  };
  return kGolden;
}

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
  Show("reply HELLO", Exchange(testing::Request(OLF_MSG_HELLO, 1)));
  Show("reply STAGE_BEGIN", Exchange(testing::Request(OLF_MSG_STAGE_BEGIN, 2)));
  const ParamSet next{72.125, 71.875, 268.25, 4000};
  uint16_t seq = 3;
  for (size_t i = 0; i < ParamTable().size(); ++i) {
    const Bytes reply = Exchange(testing::Request(OLF_MSG_STAGE_PUT, seq++, ParamBody(i, next.Get(i))));
    if (i == 2) Show("reply STAGE_PUT", reply);
  }
  Show("reply PARAMS_READ staged", Exchange(testing::Request(OLF_MSG_PARAMS_READ, seq++, {1})));
  Show("reply COMMIT wrong checksum",
       Exchange(testing::Request(OLF_MSG_COMMIT, seq++, ByteWriter().U32(0xdeadbeef).Take())));
  const uint16_t commit_seq = seq++;
  Show("reply COMMIT",
       Exchange(testing::Request(OLF_MSG_COMMIT, commit_seq, ByteWriter().U32(next.Checksum()).Take())));
  Show("reply COMMIT retry (from cache)",
       Exchange(testing::Request(OLF_MSG_COMMIT, commit_seq, ByteWriter().U32(next.Checksum()).Take())));
  Show("reply HELLO version 2", Exchange(testing::Request(OLF_MSG_HELLO, seq++, {}, 2)));
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
