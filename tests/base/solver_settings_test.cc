// SolverSettings (base/solver_settings.h), which every Ceres-using options struct holds: Ceres'
// defaults pass; a count under one or a negative tolerance fails, and `why` names it.
#include "odocal/base/solver_settings.h"

#include <limits>

#include <gtest/gtest.h>

#include "odocal/test_util/options_checks.h"

namespace odocal {
namespace {

using test_util::ExpectValidAndEachEditRejected;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(SolverSettings, CeresDefaultsAreValidAndEachBadFieldIsNamed) {
  ExpectValidAndEachEditRejected<SolverSettings>(
      {}, {{[](SolverSettings* s) { s->max_iterations = 0; }, "max_iterations"},
           {[](SolverSettings* s) { s->function_tolerance = -1e-6; }, "tolerances"},
           {[](SolverSettings* s) { s->gradient_tolerance = kNaN; }, "tolerances"},
           {[](SolverSettings* s) { s->parameter_tolerance = -1.0; }, "tolerances"},
           {[](SolverSettings* s) { s->num_threads = 0; }, "num_threads"}});
}

}  // namespace
}  // namespace odocal
