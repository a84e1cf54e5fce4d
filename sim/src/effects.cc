#include "odocal/sim/effects.h"

namespace odocal::sim {

std::vector<std::string> Effects::Names() const {
  std::vector<std::string> names;
  if (tag_offset) names.push_back("tag_offset");
  if (camera_latency) names.push_back("camera_latency");
  if (turn_slip) names.push_back("turn_slip");
  if (lens_distortion) names.push_back("lens_distortion");
  if (encoder_backlash) names.push_back("encoder_backlash");
  if (carpet_drift) names.push_back("carpet_drift");
  if (tracker_yaw) names.push_back("tracker_yaw");
  if (speed_slip) names.push_back("speed_slip");
  if (arc_scale) names.push_back("arc_scale");
  if (rolling_shutter) names.push_back("rolling_shutter");
  if (eccentric_wheel) names.push_back("eccentric_wheel");
  if (oval_wheel) names.push_back("oval_wheel");
  return names;
}

}  // namespace odocal::sim
