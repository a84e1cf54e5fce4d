// Internal: every candidate effect, one file each (calibration/src/effects/<name>.h)
// holding its descriptor (odocal/calibration/effect_registry.h) and its term in
// the model, which trajectory_fit.cc's DeadReckon and PredictFrame call in
// order. effect_registry.cc lists the descriptors.
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_EFFECTS_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_EFFECTS_H_

#include "arc_scale.h"
#include "camera_latency.h"
#include "carpet_drift.h"
#include "eccentric_wheel.h"
#include "encoder_backlash.h"
#include "lens_distortion.h"
#include "rolling_shutter.h"
#include "speed_slip.h"
#include "tag_offset.h"
#include "tracker_yaw.h"
#include "turn_slip.h"

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_EFFECTS_H_
