#include "odocal/calibration/seen_turning.h"

#include <algorithm>
#include <limits>

#include "odocal/base/format.h"
#include "odocal/base/units.h"
#include "odocal/calibration/pose2.h"

namespace odocal::calibration {
namespace {

double Deg(double rad) { return rad * kRadToDeg; }

}  // namespace

bool SeenTurningOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* text) {
    if (why) *why = text;
    return false;
  };
  if (!(max_turn_rate_rad_s > 0.0) || !std::isfinite(max_turn_rate_rad_s))
    return fail("max_turn_rate_rad_s must be a positive number");
  if (!(heading_margin_rad >= 0.0 && heading_margin_rad < M_PI)) return fail("heading_margin_rad must be in [0, pi)");
  return true;
}

SeenTurning TrackSeenTurning(const std::vector<HeadingSighting>& sightings, const SeenTurningOptions& options) {
  SeenTurning seen;
  if (sightings.empty()) return seen;
  double relative = 0.0;  // heading since the chain's first sighting
  auto start_chain = [&](const HeadingSighting& s) {
    TurnChain chain;
    chain.t_begin_s = chain.t_end_s = s.t_s;
    chain.sightings = 1;
    seen.chains.push_back(chain);
    relative = 0.0;
  };
  start_chain(sightings.front());
  for (size_t i = 1; i < sightings.size(); ++i) {
    const HeadingSighting& a = sightings[i - 1];
    const HeadingSighting& b = sightings[i];
    const double gap_s = b.t_s - a.t_s;
    const double step = WrapAngle(b.heading_rad - a.heading_rad);
    seen.largest_gap_s = std::max(seen.largest_gap_s, gap_s);
    if (!options.Bridges(step, gap_s)) {
      seen.unseen_s += gap_s;
      start_chain(b);
      continue;
    }
    TurnChain& chain = seen.chains.back();
    relative += step;
    chain.t_end_s = b.t_s;
    chain.turned_rad = relative;
    chain.lowest_rad = std::min(chain.lowest_rad, relative);
    chain.highest_rad = std::max(chain.highest_rad, relative);
    ++chain.sightings;
  }
  seen.net_wrapped_rad = WrapAngle(sightings.back().heading_rad - sightings.front().heading_rad);
  return seen;
}

std::vector<double> PlannedHeadings(const std::vector<Primitive>& plan) {
  std::vector<double> headings = {0.0};
  for (const Primitive& p : plan)
    headings.push_back(headings.back() + (p.kind == Primitive::Kind::kStraight ? 0.0 : p.amount));
  return headings;
}

std::optional<std::string> ContradictsPlan(const SeenTurning& seen, const std::vector<Primitive>& plan,
                                           double tolerance_rad) {
  if (seen.chains.empty()) return std::nullopt;
  const std::vector<double> h = PlannedHeadings(plan);
  const double planned = h.back();
  const double lowest = *std::min_element(h.begin(), h.end());
  const double highest = *std::max_element(h.begin(), h.end());
  // The least and greatest heading change over any stretch of the plan
  // (from boundary i to a later boundary j; turns are monotone between).
  double least_change = 0.0, greatest_change = 0.0;
  for (size_t i = 0; i < h.size(); ++i)
    for (size_t j = i; j < h.size(); ++j) {
      least_change = std::min(least_change, h[j] - h[i]);
      greatest_change = std::max(greatest_change, h[j] - h[i]);
    }
  if (const auto total = seen.total_rad()) {
    if (std::abs(*total - planned) > tolerance_rad)
      return Format("the camera saw the robot turn %+.0f deg, the plan turns %+.0f deg", Deg(*total), Deg(planned));
  } else if (std::abs(WrapAngle(seen.net_wrapped_rad - planned)) > tolerance_rad) {
    // Start and end are seen: the heading modulo a turn is always known.
    return Format(
        "the camera saw the robot end %+.0f deg from the plan's heading (modulo a turn; the plan turns "
        "%+.0f deg)",
        Deg(WrapAngle(seen.net_wrapped_rad - planned)), Deg(planned));
  }
  // A chain's turning outside what the plan turns over the same kind of
  // stretch (from the start, to the end, or any).
  for (size_t k = 0; k < seen.chains.size(); ++k) {
    const TurnChain& c = seen.chains[k];
    auto outside = [&](double seen_low, double seen_high, double plan_low, double plan_high,
                       const char* stretch) -> std::optional<std::string> {
      const bool low = seen_low < plan_low - tolerance_rad;
      if (!low && seen_high <= plan_high + tolerance_rad) return std::nullopt;
      return Format(
          "while in view at %.1f-%.1f s the camera saw the robot turn %+.0f deg%s, where the plan turns "
          "between %+.0f and %+.0f deg",
          c.t_begin_s, c.t_end_s, Deg(low ? seen_low : seen_high), stretch, Deg(plan_low), Deg(plan_high));
    };
    std::optional<std::string> why;
    if (k == 0) why = outside(c.lowest_rad, c.highest_rad, lowest, highest, " from the start");
    // To the end: from a heading r of the chain the robot turned
    // (turned - r) more.
    if (!why && k > 0 && k + 1 == seen.chains.size())
      why = outside(c.turned_rad - c.highest_rad, c.turned_rad - c.lowest_rad, planned - highest, planned - lowest,
                    " before the end");
    if (!why) why = outside(c.lowest_rad, c.highest_rad, least_change, greatest_change, " over a stretch");
    if (why) return why;
  }
  return std::nullopt;
}

}  // namespace odocal::calibration
