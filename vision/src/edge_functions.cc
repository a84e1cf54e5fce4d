#include "odocal/vision/internal/edge_functions.h"

#include <vector>

namespace odocal::vision::internal {

const double* NormalTable() {
  static const std::vector<double> table = [] {
    const int nodes = static_cast<int>(2.0 * kNormalRange * kNormalNodesPerUnit) + 2;
    std::vector<double> t(4 * static_cast<size_t>(nodes));
    for (int i = 0; i < nodes; ++i) {
      const double z = -kNormalRange + static_cast<double>(i) / kNormalNodesPerUnit;
      const double pdf = std::exp(-0.5 * z * z) * (0.5 * M_2_SQRTPI * M_SQRT1_2);
      t[4 * i] = 0.5 * std::erfc(-z * M_SQRT1_2);
      t[4 * i + 1] = pdf;
      t[4 * i + 2] = -z * pdf;
      t[4 * i + 3] = (z * z - 1.0) * pdf;
    }
    return t;
  }();
  return table.data();
}

}  // namespace odocal::vision::internal
