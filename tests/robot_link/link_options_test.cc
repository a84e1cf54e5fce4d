// IsValid of robot_link's options and of the parameter set: the defaults (for ParamSet, a typical
// robot's set) pass; a field out of range fails, and `why` names it.
#include <chrono>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "odocal/robot_link/client.h"
#include "odocal/robot_link/fault_injection.h"
#include "odocal/robot_link/firmware_host.h"
#include "odocal/robot_link/params.h"
#include "odocal/robot_link/serial_transport.h"
#include "odocal/test_util/options_checks.h"

namespace odocal::robot_link {
namespace {

using namespace std::chrono_literals;
using test_util::ExpectValidAndEachEditRejected;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(ClientOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<ClientOptions>(
      {}, {{[](ClientOptions* o) { o->reply_timeout = 0ms; }, "reply_timeout"},
           {[](ClientOptions* o) { o->status_poll_interval = -1ms; }, "status_poll_interval"},
           {[](ClientOptions* o) { o->max_attempts = 0; }, "max_attempts"}});
}

TEST(FaultOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<FaultOptions>(
      {}, {{[](FaultOptions* o) { o->corrupt_probability = 1.5; }, "corrupt_probability must be in [0, 1]"},
           {[](FaultOptions* o) { o->drop_probability = -0.1; }, "drop_probability"},
           {[](FaultOptions* o) { o->duplicate_probability = kNaN; }, "duplicate_probability"},
           {[](FaultOptions* o) { o->delay_probability = 2.0; }, "delay_probability"},
           {[](FaultOptions* o) { o->delay = -1ms; }, "delay"}});
}

TEST(FirmwareHostOptions, DefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<FirmwareHostOptions>(
      {}, {{[](FirmwareHostOptions* o) { o->tick = 0ms; }, "tick"},
           {[](FirmwareHostOptions* o) { o->time_scale = 0.0; }, "time_scale"},
           {[](FirmwareHostOptions* o) { o->time_scale = kNaN; }, "time_scale"}});
}

TEST(SerialOptions, DefaultsAreValidAndAnUnsupportedBaudIsNamed) {
  ExpectValidAndEachEditRejected<SerialOptions>({}, {{[](SerialOptions* o) { o->baud = 0; }, "unsupported baud rate 0"},
                                                     {[](SerialOptions* o) { o->baud = 115201; }, "115201"}});
}

// The firmware table's ranges, bounds included: `why` names the parameter and its range.
TEST(ParamSet, ATypicalSetIsValidAndEachParameterOutOfItsRangeIsNamed) {
  std::string why;
  EXPECT_FALSE(ParamSet{}.IsValid(&why)) << "all zero";
  const ParamSet bounds{1.0, 2000.0, 10.0, 16777216};
  EXPECT_TRUE(bounds.IsValid(&why)) << why;
  ExpectValidAndEachEditRejected<ParamSet>(
      ParamSet{70.0, 70.2, 300.0, 2048},
      {{[](ParamSet* p) { p->left_wheel_diameter_mm = 0.5; }, "left_wheel_diameter_mm = 0.5 is outside [1, 2000]"},
       {[](ParamSet* p) { p->right_wheel_diameter_mm = 2000.5; }, "right_wheel_diameter_mm"},
       {[](ParamSet* p) { p->track_mm = kNaN; }, "track_mm"},
       {[](ParamSet* p) { p->ticks_per_rev = 0; }, "ticks_per_rev"},
       {[](ParamSet* p) { p->ticks_per_rev = 16777217; }, "ticks_per_rev"}});
}

}  // namespace
}  // namespace odocal::robot_link
