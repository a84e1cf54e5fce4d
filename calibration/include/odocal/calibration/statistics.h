// Small statistics used by the estimators: sample moments and first-order
// propagation of independent uncertainties through a function.
#ifndef ODOCAL_CALIBRATION_STATISTICS_H_
#define ODOCAL_CALIBRATION_STATISTICS_H_

#include <functional>
#include <optional>
#include <vector>

namespace odocal::calibration {

double Mean(const std::vector<double>& values);

// The middle value (of an even count, the upper of the two middle ones: a
// value the data hold, as robust estimates of scatter want); 0 for none.
double Median(std::vector<double> values);
// Sample standard deviation (n - 1); nullopt for fewer than two values.
std::optional<double> SampleStdDev(const std::vector<double>& values);
// Standard error of the mean; nullopt for fewer than two values.
std::optional<double> StandardError(const std::vector<double>& values);

// sigma of f(x) for independent inputs x_i with standard deviations sigma_i,
// to first order, with central differences scaled to each sigma.
double PropagateIndependent(const std::function<double(const std::vector<double>&)>& f,
                            const std::vector<double>& x, const std::vector<double>& sigma);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_STATISTICS_H_
