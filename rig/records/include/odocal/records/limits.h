// A production line's acceptance limits, and the verdict of one record against them: PASS when
// every limit holds, FAIL naming each that does not (a quantity the run did not measure fails
// a limit on it: a unit that could not be checked is not passed).
//
//   Result<Limits> limits = records::ParseLimits("emax_syst_after_mm=2,ed=0.5%,eb=2%");
//   records::Judge(*limits, &record);   // record.verdict, record.failed_limits
#ifndef ODOCAL_RECORDS_LIMITS_H_
#define ODOCAL_RECORDS_LIMITS_H_

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "odocal/base/status.h"
#include "odocal/records/record.h"

namespace odocal::records {

struct Limits {
  std::optional<double> emax_syst_after_mm;   // E_max,syst measured with the calibrated set <=
  std::optional<double> emax_syst_before_mm;  // E_max,syst as the robot came <= (an incoming check)
  std::optional<double> ed_tolerance;         // |Ed - 1| <= (a fraction: 0.005 is 0.5 %)
  std::optional<double> eb_tolerance;         // |Eb - 1| <=
  std::optional<double> recalibrate_days;     // a fleet's interval: a robot is due this long after its last
  bool empty() const {
    return !emax_syst_after_mm && !emax_syst_before_mm && !ed_tolerance && !eb_tolerance && !recalibrate_days;
  }
};

// "KEY=VALUE,KEY=VALUE" with keys emax_syst_after_mm, emax_syst_before_mm, ed, eb (a fraction, or
// a percentage with %), recalibrate_days. An unknown key, a value that is not a positive number:
// an error naming it.
Result<Limits> ParseLimits(const std::string& text);
nlohmann::json LimitsJson(const Limits& limits);
// The limits a LimitsJson wrote (the keys above; missing = no limit).
Result<Limits> LimitsFromJson(const nlohmann::json& j);
// "E_max,syst after <= 2 mm, |Ed - 1| <= 0.5 %"
std::string Describe(const Limits& limits);

// Sets record->verdict (kNone when `limits` has no acceptance limit) and failed_limits, each in
// words with the value found ("E_max,syst after 2.61 mm > 2 mm").
void Judge(const Limits& limits, Record* record);

}  // namespace odocal::records

#endif  // ODOCAL_RECORDS_LIMITS_H_
