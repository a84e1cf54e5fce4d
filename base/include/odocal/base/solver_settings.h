// The settings of a nonlinear least-squares solve, as the Options struct of an
// algorithm carries them (each algorithm documents its own defaults there).
// The fields mirror ceres::Solver::Options; ApplyTo copies them without this
// header including Ceres, so modules that do not link Ceres can hold them.
// The linear solver is not a setting: it follows from the problem's
// structure and stays with the code that builds the problem.
#ifndef ODOCAL_BASE_SOLVER_SETTINGS_H_
#define ODOCAL_BASE_SOLVER_SETTINGS_H_

#include <string>

namespace odocal {

struct SolverSettings {
  int max_iterations = 50;             // Ceres' default
  double function_tolerance = 1e-6;    // relative change of the cost; Ceres' default
  double gradient_tolerance = 1e-10;   // max-norm of the projected gradient; Ceres' default
  double parameter_tolerance = 1e-8;   // relative change of the parameters; Ceres' default
  int num_threads = 1;

  bool IsValid(std::string* why) const {
    auto fail = [why](const char* m) {
      if (why) *why = m;
      return false;
    };
    if (max_iterations < 1) return fail("solver max_iterations must be at least 1");
    if (!(function_tolerance >= 0.0) || !(gradient_tolerance >= 0.0) ||
        !(parameter_tolerance >= 0.0))
      return fail("solver tolerances must not be negative");
    if (num_threads < 1) return fail("solver num_threads must be at least 1");
    return true;
  }
};

// Copies the settings into a ceres::Solver::Options (a template so that this
// header does not need Ceres).
template <typename CeresSolverOptions>
void ApplyTo(const SolverSettings& settings, CeresSolverOptions* options) {
  options->max_num_iterations = settings.max_iterations;
  options->function_tolerance = settings.function_tolerance;
  options->gradient_tolerance = settings.gradient_tolerance;
  options->parameter_tolerance = settings.parameter_tolerance;
  options->num_threads = settings.num_threads;
}

}  // namespace odocal

#endif  // ODOCAL_BASE_SOLVER_SETTINGS_H_
