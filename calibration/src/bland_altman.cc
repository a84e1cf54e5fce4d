#include "odocal/calibration/bland_altman.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <ostream>
#include <sstream>

#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>

#include "odocal/calibration/statistics.h"

namespace odocal::calibration {
namespace {

BlandAltmanResult Invalid(const std::string& why) {
  BlandAltmanResult r;
  r.status = StatusCode::kInvalidArgument;
  r.message = why;
  return r;
}

}  // namespace

bool BlandAltmanOptions::IsValid(std::string* why) const {
  if (!(confidence > 0.5 && confidence < 1.0)) {
    if (why) *why = "confidence must be in (0.5, 1)";
    return false;
  }
  if (!(outlier_confidence > 0.5 && outlier_confidence < 1.0)) {
    if (why) *why = "outlier_confidence must be in (0.5, 1)";
    return false;
  }
  return true;
}

double BlandAltmanResult::error_bound() const { return std::abs(bias) + z * sd; }

std::ostream& operator<<(std::ostream& os, const Interval& i) {
  return os << "[" << i.lower << ", " << i.upper << "]";
}

std::string BlandAltmanResult::BriefReport() const {
  std::ostringstream os;
  if (!ok()) return "Bland-Altman: " + message;
  os << std::fixed << std::setprecision(3);
  os << "n " << n << ", bias " << bias << " (CI " << bias_ci << "), sd " << sd << ", limits "
     << lower_limit << " (CI " << lower_limit_ci << ") to " << upper_limit << " (CI "
     << upper_limit_ci << "), " << outliers.size() << " outlier(s)";
  return os.str();
}

BlandAltmanResult BlandAltman(const std::vector<double>& test, const std::vector<double>& reference,
                              const BlandAltmanOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return Invalid(why);
  if (test.size() != reference.size())
    return Invalid("test and reference have different lengths (" + std::to_string(test.size()) +
                   " and " + std::to_string(reference.size()) + ")");
  if (test.size() < 3)
    return Invalid("needs at least 3 pairs, got " + std::to_string(test.size()));
  BlandAltmanResult r;
  r.n = static_cast<int>(test.size());
  for (size_t i = 0; i < test.size(); ++i) {
    if (!std::isfinite(test[i]) || !std::isfinite(reference[i]))
      return Invalid("pair " + std::to_string(i + 1) + " is not finite");
    r.differences.push_back(test[i] - reference[i]);
    r.means.push_back(0.5 * (test[i] + reference[i]));
  }
  r.bias = Mean(r.differences);
  r.sd = *SampleStdDev(r.differences);
  const double tail = 0.5 * (1.0 + options.confidence);
  r.z = boost::math::quantile(boost::math::normal_distribution<double>(0.0, 1.0), tail);
  r.t = boost::math::quantile(boost::math::students_t_distribution<double>(r.n - 1), tail);
  r.lower_limit = r.bias - r.z * r.sd;
  r.upper_limit = r.bias + r.z * r.sd;
  const double se_bias = r.sd / std::sqrt(double(r.n));
  r.bias_ci = {r.bias - r.t * se_bias, r.bias + r.t * se_bias};
  const double se_limit = r.sd * std::sqrt(1.0 / r.n + r.z * r.z / (2.0 * (r.n - 1)));
  r.lower_limit_ci = {r.lower_limit - r.t * se_limit, r.lower_limit + r.t * se_limit};
  r.upper_limit_ci = {r.upper_limit - r.t * se_limit, r.upper_limit + r.t * se_limit};

  const double t_out = boost::math::quantile(
      boost::math::students_t_distribution<double>(r.n - 2), 0.5 * (1.0 + options.outlier_confidence));
  double sum = 0.0, sum_sq = 0.0;
  for (double d : r.differences) {
    sum += d - r.bias;
    sum_sq += (d - r.bias) * (d - r.bias);
  }
  for (int i = 0; i < r.n; ++i) {
    const double d = r.differences[i];
    // Mean and SD of the others, from the sums about the full mean.
    const double e = d - r.bias;
    const double mean_others = r.bias + (sum - e) / (r.n - 1);
    const double ss_others = sum_sq - e * e - (r.n - 1) * std::pow(mean_others - r.bias, 2);
    const double sd_others = std::sqrt(std::max(0.0, ss_others) / (r.n - 2));
    const double bound = t_out * sd_others * std::sqrt(1.0 + 1.0 / (r.n - 1));
    if (std::abs(d - mean_others) > bound && std::abs(d - mean_others) > 1e-12 * (1.0 + std::abs(d)))
      r.outliers.push_back(i);
    if (d < r.lower_limit || d > r.upper_limit) r.outside_limits.push_back(i);
  }
  r.status = StatusCode::kOk;
  return r;
}

}  // namespace odocal::calibration
