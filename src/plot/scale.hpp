// Axis arithmetic: "nice" tick values (1, 2, 2.5 or 5 times a power of ten), their labels, and the
// linear map from data values to pixels.
#pragma once

#include <string>
#include <vector>

#include "plot/figure.hpp"

namespace desslam::plot {

// The tick step for about `target_ticks` ticks over [lo, hi]: 1, 2, 2.5 or 5 times a power of
// ten. lo < hi, both finite.
double niceStep(double lo, double hi, int target_ticks = 6);

// [lo, hi] widened outwards to multiples of niceStep(lo, hi). An empty or non-finite range
// becomes a small one around its value (or [0, 1]) so that an axis can always be drawn.
Range niceRange(double lo, double hi, int target_ticks = 6);

// The multiples of `step` inside [range.min, range.max] (ends included up to rounding), exact
// decimals (0.3, not 0.30000000000000004).
std::vector<double> ticksInside(const Range& range, double step);

// A tick's label with as many decimals as the step needs ("0.25", "10", "-0.5", never "-0").
std::string formatTick(double value, double step);

// Maps data [d0, d1] linearly onto pixels [p0, p1] (p1 < p0 for a y axis: SVG's y grows down).
struct LinearScale {
  double d0 = 0, d1 = 1, p0 = 0, p1 = 1;
  double operator()(double v) const { return p0 + (v - d0) * (p1 - p0) / (d1 - d0); }
};

}  // namespace desslam::plot
