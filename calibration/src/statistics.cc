#include "odocal/calibration/statistics.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numeric>

namespace odocal::calibration {

double Mean(const std::vector<double>& values) {
  assert(!values.empty());
  return std::accumulate(values.begin(), values.end(), 0.0) / values.size();
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

std::optional<double> SampleStdDev(const std::vector<double>& values) {
  if (values.size() < 2) return std::nullopt;
  const double mean = Mean(values);
  double sum_sq = 0.0;
  for (double v : values) sum_sq += (v - mean) * (v - mean);
  return std::sqrt(sum_sq / (values.size() - 1));
}

std::optional<double> StandardError(const std::vector<double>& values) {
  const std::optional<double> sd = SampleStdDev(values);
  if (!sd) return std::nullopt;
  return *sd / std::sqrt(static_cast<double>(values.size()));
}

double PropagateIndependent(const std::function<double(const std::vector<double>&)>& f,
                            const std::vector<double>& x, const std::vector<double>& sigma) {
  assert(x.size() == sigma.size());
  double variance = 0.0;
  for (size_t i = 0; i < x.size(); ++i) {
    if (sigma[i] <= 0.0) continue;
    // A step of a tenth of a sigma keeps the difference inside the linear range
    // while staying far above rounding.
    const double h = 0.1 * sigma[i];
    std::vector<double> plus = x, minus = x;
    plus[i] += h;
    minus[i] -= h;
    const double derivative = (f(plus) - f(minus)) / (2.0 * h);
    variance += derivative * derivative * sigma[i] * sigma[i];
  }
  return std::sqrt(variance);
}

}  // namespace odocal::calibration
