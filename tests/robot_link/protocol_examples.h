// The protocol's byte-level examples (docs/protocol.md): the golden bytes,
// and the push conversation that produces them. Replayed against the virtual
// robot (link_protocol_examples_test) and against the firmware running on
// emulated microcontrollers (link_emulated_test).
#ifndef ODOCAL_TESTS_ROBOT_LINK_PROTOCOL_EXAMPLES_H_
#define ODOCAL_TESTS_ROBOT_LINK_PROTOCOL_EXAMPLES_H_

#include <map>
#include <string>
#include <vector>

#include "link_test_util.h"
#include "odocal/robot_link/codec.h"
#include "odocal/robot_link/params.h"

namespace odocal::robot_link {

// Golden hex, copied into docs/protocol.md.
inline const std::map<std::string, std::string>& Golden() {
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

// One request of the conversation, and the golden name of its reply ("" when
// the reply is not one of the documented examples).
struct Example {
  Frame request;
  std::string reply_name;
};

// HELLO, a staged push of `kExamplePushed` with a wrong and a right commit, the
// commit retried (answered from the cache), HELLO with protocol version 2.
inline const ParamSet kExamplePushed{72.125, 71.875, 268.25, 4000};

inline std::vector<Example> PushConversation() {
  std::vector<Example> c;
  c.push_back({testing::Request(OLF_MSG_HELLO, 1), "reply HELLO"});
  c.push_back({testing::Request(OLF_MSG_STAGE_BEGIN, 2), "reply STAGE_BEGIN"});
  uint16_t seq = 3;
  for (size_t i = 0; i < ParamTable().size(); ++i) {
    c.push_back({testing::Request(OLF_MSG_STAGE_PUT, seq++, ParamBody(i, kExamplePushed.Get(i))),
                 i == 2 ? "reply STAGE_PUT" : ""});
  }
  c.push_back({testing::Request(OLF_MSG_PARAMS_READ, seq++, {1}), "reply PARAMS_READ staged"});
  c.push_back({testing::Request(OLF_MSG_COMMIT, seq++, ByteWriter().U32(0xdeadbeef).Take()),
               "reply COMMIT wrong checksum"});
  const uint16_t commit_seq = seq++;
  const Bytes commit = ByteWriter().U32(kExamplePushed.Checksum()).Take();
  c.push_back({testing::Request(OLF_MSG_COMMIT, commit_seq, commit), "reply COMMIT"});
  c.push_back({testing::Request(OLF_MSG_COMMIT, commit_seq, commit), "reply COMMIT retry (from cache)"});
  c.push_back({testing::Request(OLF_MSG_HELLO, seq++, {}, 2), "reply HELLO version 2"});
  return c;
}

}  // namespace odocal::robot_link

#endif  // ODOCAL_TESTS_ROBOT_LINK_PROTOCOL_EXAMPLES_H_
