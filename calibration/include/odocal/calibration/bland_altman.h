// Agreement between two ways of measuring the same quantity (Bland & Altman,
// "Statistical methods for assessing agreement between two methods of clinical
// measurement", Lancet 1986; limits' confidence intervals from Bland & Altman,
// "Measuring agreement in method comparison studies", Stat. Methods Med. Res.
// 1999, section 2.2).
//
// Used by `odocal validate`: the tape-measured return error of each run
// (the method under test) against the camera's (the reference). Differences are
// test - reference, in whatever unit the caller uses (the CLI: mm and degrees).
//
//   bias   d̄ = mean(d_i),  s = sample SD of d_i (n - 1)
//   limits of agreement  d̄ ± z s,  z = the normal quantile of (1 + confidence) / 2
//   CI of the bias       d̄ ± t_{n-1} s / √n
//   CI of each limit     limit ± t_{n-1} s √(1/n + z² / (2 (n - 1)))
//
// Outliers: a difference outside the prediction interval of the others
// (leave-one-out, so that one wild tape reading does not hide itself by
// inflating s): |d_i - mean_{-i}| > t_{n-2, (1+c)/2} s_{-i} sqrt(1 + 1/(n-1)),
// c = outlier_confidence (0.999: one false flag in a thousand normal
// readings). Points outside the limits of agreement are listed too (about 1 in
// 20 is expected there by construction).
//
// Pure function of the numbers: no I/O.
#ifndef ODOCAL_CALIBRATION_BLAND_ALTMAN_H_
#define ODOCAL_CALIBRATION_BLAND_ALTMAN_H_

#include <iosfwd>
#include <string>
#include <vector>

#include "odocal/base/status.h"

namespace odocal::calibration {

struct BlandAltmanOptions {
  double confidence = 0.95;           // of the limits and of every interval
  double outlier_confidence = 0.999;  // of the leave-one-out prediction interval

  bool IsValid(std::string* why) const;
};

struct Interval {
  double lower = 0.0;
  double upper = 0.0;
  bool Contains(double v) const { return lower <= v && v <= upper; }
  double half_width() const { return 0.5 * (upper - lower); }
};

struct BlandAltmanResult {
  StatusCode status = StatusCode::kInvalidArgument;
  std::string message;

  int n = 0;
  std::vector<double> differences;  // test - reference, per pair
  std::vector<double> means;        // (test + reference) / 2, per pair
  double bias = 0.0;                // mean difference
  double sd = 0.0;                  // sample SD of the differences
  double z = 0.0;                   // normal quantile used for the limits
  double t = 0.0;                   // Student's t quantile, n - 1 degrees of freedom
  double lower_limit = 0.0;         // bias - z sd
  double upper_limit = 0.0;         // bias + z sd
  Interval bias_ci;
  Interval lower_limit_ci;
  Interval upper_limit_ci;
  std::vector<int> outliers;        // indices outside the others' prediction interval
  std::vector<int> outside_limits;  // indices outside [lower_limit, upper_limit]

  bool ok() const { return status == StatusCode::kOk; }
  // The error of a single test reading at the given confidence: |bias| + z sd
  // (how far one tape reading may be from the reference).
  double error_bound() const;
  std::string BriefReport() const;
};

std::ostream& operator<<(std::ostream& os, const Interval& i);

// `test` and `reference` pair up by index. Needs n >= 3 pairs (n - 1 >= 2
// degrees of freedom for a usable t), finite values, and equal lengths.
BlandAltmanResult BlandAltman(const std::vector<double>& test, const std::vector<double>& reference,
                              const BlandAltmanOptions& options = {});

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_BLAND_ALTMAN_H_
