#include "plot/scale.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace desslam::plot {

double niceStep(double lo, double hi, int target_ticks) {
  const double raw = (hi - lo) / std::max(1, target_ticks - 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double fraction = raw / magnitude;  // in [1, 10)
  // The tolerance keeps a fraction that is 1, 2, 2.5 or 5 up to rounding (0.3 / 3 = 0.09999...)
  // on that step rather than the next one.
  constexpr double kTolerance = 1e-9;
  const double nice = fraction <= 1.0 + kTolerance   ? 1.0
                      : fraction <= 2.0 + kTolerance ? 2.0
                      : fraction <= 2.5 + kTolerance ? 2.5
                      : fraction <= 5.0 + kTolerance ? 5.0
                                                     : 10.0;
  return nice * magnitude;
}

Range niceRange(double lo, double hi, int target_ticks) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) return {0, 1};
  if (lo > hi) std::swap(lo, hi);
  // A flat series (one value, a constant) still needs an axis: a span around it.
  if (hi - lo <= 1e-12 * std::max(1.0, std::abs(lo))) {
    const double pad = lo == 0 ? 1.0 : 0.1 * std::abs(lo);
    lo -= pad;
    hi += pad;
  }
  const double step = niceStep(lo, hi, target_ticks);
  // The small tolerance keeps a value that is a multiple of the step up to rounding on its tick.
  return {std::floor(lo / step + 1e-9) * step, std::ceil(hi / step - 1e-9) * step};
}

std::vector<double> ticksInside(const Range& range, double step) {
  std::vector<double> ticks;
  if (!(step > 0) || !std::isfinite(range.min) || !std::isfinite(range.max)) return ticks;
  const double first = std::ceil(range.min / step - 1e-9), last = std::floor(range.max / step + 1e-9);
  for (double k = first; k <= last && ticks.size() < 1000; k += 1.0) ticks.push_back(k * step);
  return ticks;
}

std::string formatTick(double value, double step) {
  // Enough decimals that the step itself is written exactly (0.25 needs two, 5 none).
  int decimals = 0;
  for (double scaled = step; decimals < 9 && std::abs(scaled - std::round(scaled)) > 1e-6 * std::max(1.0, scaled);
       scaled *= 10.0)
    ++decimals;
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  std::string label = text;
  if (label.find_first_not_of("-0.") == std::string::npos && label[0] == '-') label.erase(0, 1);  // "-0.0"
  return label;
}

}  // namespace desslam::plot
