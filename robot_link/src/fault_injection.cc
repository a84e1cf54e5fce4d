#include "odocal/robot_link/fault_injection.h"

#include <cassert>
#include <string>
#include <thread>
#include <utility>

namespace odocal::robot_link {

bool FaultOptions::IsValid(std::string* why) const {
  const std::pair<const char*, double> probabilities[] = {{"corrupt_probability", corrupt_probability},
                                                          {"drop_probability", drop_probability},
                                                          {"duplicate_probability", duplicate_probability},
                                                          {"delay_probability", delay_probability}};
  for (const auto& [name, p] : probabilities) {
    if (!(p >= 0.0 && p <= 1.0)) {
      if (why) *why = std::string(name) + " must be in [0, 1] (a fault probability)";
      return false;
    }
  }
  if (delay.count() < 0) {
    if (why) *why = "delay must not be negative";
    return false;
  }
  return true;
}

FaultInjectingTransport::FaultInjectingTransport(Transport& inner, const FaultOptions& options)
    : inner_(inner), options_(options), rng_(options.seed) {
  assert(options.IsValid(nullptr) && "FaultOptions out of range");
}

bool FaultInjectingTransport::Chance(double p) {
  if (p <= 0.0) return false;
  return std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < p;
}

bool FaultInjectingTransport::Damage(std::span<const uint8_t> in, std::deque<uint8_t>* out,
                                     bool* delay) {
  for (uint8_t b : in) {
    if (counters_.cut) return false;
    if (options_.cut_after_bytes && counters_.bytes >= *options_.cut_after_bytes) {
      counters_.cut = true;
      return false;
    }
    ++counters_.bytes;
    if (Chance(options_.drop_probability)) {
      ++counters_.dropped;
      continue;
    }
    if (Chance(options_.corrupt_probability)) {
      b ^= static_cast<uint8_t>(std::uniform_int_distribution<int>(1, 255)(rng_));
      ++counters_.corrupted;
    }
    out->push_back(b);
    if (Chance(options_.duplicate_probability)) {
      out->push_back(b);
      ++counters_.duplicated;
    }
    if (delay && Chance(options_.delay_probability)) {
      ++counters_.delayed;
      *delay = true;
    }
  }
  return !counters_.cut;
}

IoResult FaultInjectingTransport::Write(std::span<const uint8_t> data) {
  std::deque<uint8_t> damaged;
  bool delay = false;
  const bool alive = Damage(data, &damaged, &delay);
  if (delay) std::this_thread::sleep_for(options_.delay);
  if (!damaged.empty()) {
    const std::vector<uint8_t> bytes(damaged.begin(), damaged.end());
    IoResult r = inner_.Write(bytes);
    if (r.status != IoStatus::kOk) return r;
  }
  if (!alive) return {IoStatus::kClosed, 0, "line to " + inner_.Describe() + " cut"};
  return {IoStatus::kOk, data.size(), ""};
}

IoResult FaultInjectingTransport::Read(std::span<uint8_t> buffer,
                                       std::chrono::milliseconds timeout) {
  if (pending_read_.empty()) {
    if (counters_.cut) return {IoStatus::kClosed, 0, "line to " + inner_.Describe() + " cut"};
    std::vector<uint8_t> raw(buffer.size());
    IoResult r = inner_.Read(raw, timeout);
    if (r.status != IoStatus::kOk) return r;
    bool delay = false;
    Damage(std::span(raw.data(), r.bytes), &pending_read_, &delay);
    // Late bytes: a transport timeout would be the client's business, so the
    // bytes still come, just after the delay.
    if (delay) std::this_thread::sleep_for(options_.delay);
    if (pending_read_.empty()) {
      if (counters_.cut) return {IoStatus::kClosed, 0, "line to " + inner_.Describe() + " cut"};
      return {IoStatus::kTimeout, 0, ""};
    }
  }
  size_t n = 0;
  while (n < buffer.size() && !pending_read_.empty()) {
    buffer[n++] = pending_read_.front();
    pending_read_.pop_front();
  }
  return {IoStatus::kOk, n, ""};
}

std::string FaultInjectingTransport::Describe() const {
  return inner_.Describe() + " (fault-injected)";
}

}  // namespace odocal::robot_link
