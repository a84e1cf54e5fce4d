// A Transport wrapper that damages the byte stream the way real links do:
// corrupted bytes (noise), dropped bytes (overruns), duplicated bytes (bad
// USB adapters), delays (scheduling, buffering) and a cut line (cable pulled).
// Seeded std::mt19937: the same seed gives the same damage, so a failing
// test replays exactly.
#ifndef ODOCAL_ROBOT_LINK_FAULT_INJECTION_H_
#define ODOCAL_ROBOT_LINK_FAULT_INJECTION_H_

#include <chrono>
#include <cstdint>
#include <deque>
#include <optional>
#include <random>

#include "odocal/robot_link/transport.h"

namespace odocal::robot_link {

struct FaultOptions {
  uint32_t seed = 1;
  // Per-byte probabilities, applied independently in both directions.
  double corrupt_probability = 0.0;    // XOR with a random non-zero mask
  double drop_probability = 0.0;
  double duplicate_probability = 0.0;
  double delay_probability = 0.0;      // deliver this chunk late
  std::chrono::milliseconds delay{1};  // and sleep this long
  // Cut the line for good after this many bytes in total (both directions).
  std::optional<uint64_t> cut_after_bytes;

  bool IsValid(std::string* why) const;
};

class FaultInjectingTransport final : public Transport {
 public:
  struct Counters {
    uint64_t bytes = 0;
    uint64_t corrupted = 0;
    uint64_t dropped = 0;
    uint64_t duplicated = 0;
    uint64_t delayed = 0;
    bool cut = false;
  };

  FaultInjectingTransport(Transport& inner, const FaultOptions& options);
  IoResult Write(std::span<const uint8_t> data) override;
  IoResult Read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) override;
  std::string Describe() const override;

  const Counters& counters() const { return counters_; }
  // Cuts the line now (as if the cable were pulled).
  void Cut() { counters_.cut = true; }

 private:
  // Applies the faults to `in`, appending to `out`; false once the line is cut.
  bool Damage(std::span<const uint8_t> in, std::deque<uint8_t>* out, bool* delay);
  bool Chance(double p);

  Transport& inner_;
  FaultOptions options_;
  std::mt19937 rng_;
  std::deque<uint8_t> pending_read_;  // damaged bytes not yet handed out
  Counters counters_;
};

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_FAULT_INJECTION_H_
