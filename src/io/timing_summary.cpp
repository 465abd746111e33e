#include "io/timing_summary.hpp"

#include <algorithm>

namespace desslam::io {

nlohmann::json summarizeMilliseconds(std::vector<double> values) {
  if (values.empty()) return {{"median", 0.0}, {"p95", 0.0}, {"mean", 0.0}, {"count", 0}};
  std::sort(values.begin(), values.end());
  auto quantile = [&](double q) { return values[static_cast<size_t>(q * (values.size() - 1) + 0.5)]; };
  double sum = 0;
  for (double v : values) sum += v;
  return {{"median", quantile(0.5)}, {"p95", quantile(0.95)}, {"mean", sum / values.size()}, {"count", values.size()}};
}

}  // namespace desslam::io
