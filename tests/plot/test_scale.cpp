#include <cmath>

#include <gtest/gtest.h>

#include "plot/scale.hpp"

namespace desslam::plot {
namespace {

TEST(PlotScale, StepsAreOneTwoTwoAndAHalfOrFiveTimesAPowerOfTen) {
  EXPECT_DOUBLE_EQ(niceStep(0, 1, 6), 0.2);
  EXPECT_DOUBLE_EQ(niceStep(0, 10, 6), 2.0);
  EXPECT_DOUBLE_EQ(niceStep(0, 0.37, 6), 0.1);     // raw 0.074
  EXPECT_DOUBLE_EQ(niceStep(0, 12, 6), 2.5);       // raw 2.4
  EXPECT_DOUBLE_EQ(niceStep(-300, 1700, 5), 500);  // raw 500
  EXPECT_DOUBLE_EQ(niceStep(0, 0.003, 4), 0.001);
  for (double hi : {0.013, 0.7, 3.3, 47.0, 910.0, 1.3e5}) {
    const double step = niceStep(0, hi, 6);
    const double mantissa = step / std::pow(10.0, std::floor(std::log10(step)));
    EXPECT_TRUE(std::abs(mantissa - 1) < 1e-9 || std::abs(mantissa - 2) < 1e-9 || std::abs(mantissa - 2.5) < 1e-9 ||
                std::abs(mantissa - 5) < 1e-9)
        << hi << " -> " << step;
    EXPECT_LE(hi / step, 5.0 + 1e-9) << "about 6 ticks at most";
    EXPECT_GE(hi / step, 2.0) << "not too few";
  }
}

TEST(PlotScale, NiceRangeCoversTheDataOnTickMultiples) {
  const Range r = niceRange(0.013, 0.472);
  EXPECT_LE(r.min, 0.013);
  EXPECT_GE(r.max, 0.472);
  const double step = niceStep(r.min, r.max);
  EXPECT_NEAR(std::remainder(r.min, step), 0.0, 1e-12);
  EXPECT_NEAR(std::remainder(r.max, step), 0.0, 1e-12);
  EXPECT_LT(r.max - r.min, 2.0 * (0.472 - 0.013)) << "not much wider than the data";

  const Range negative = niceRange(-2.3, -0.4);
  EXPECT_LE(negative.min, -2.3);
  EXPECT_GE(negative.max, -0.4);
  EXPECT_LE(negative.max, 0.0);

  // Degenerate input still gives a drawable axis around the value.
  const Range flat = niceRange(5, 5);
  EXPECT_LT(flat.min, 5);
  EXPECT_GT(flat.max, 5);
  const Range zero = niceRange(0, 0);
  EXPECT_LT(zero.min, 0);
  EXPECT_GT(zero.max, 0);
  const Range nan = niceRange(std::nan(""), 1);
  EXPECT_DOUBLE_EQ(nan.min, 0);
  EXPECT_DOUBLE_EQ(nan.max, 1);
  const Range swapped = niceRange(3, 1);
  EXPECT_LE(swapped.min, 1);
  EXPECT_GE(swapped.max, 3);
}

TEST(PlotScale, TicksAreTheStepMultiplesInsideTheRange) {
  const std::vector<double> ticks = ticksInside({-0.05, 0.5}, 0.1);
  ASSERT_EQ(ticks.size(), 6u);  // 0, 0.1, ..., 0.5 (0.5 kept despite rounding)
  EXPECT_NEAR(ticks.front(), 0.0, 1e-12);
  EXPECT_NEAR(ticks.back(), 0.5, 1e-12);
  EXPECT_EQ(ticksInside({0, 1}, 0).size(), 0u);
  EXPECT_EQ(ticksInside({0, 1}, -1).size(), 0u);
  EXPECT_LE(ticksInside({0, 1e12}, 1e-3).size(), 1000u) << "bounded";
}

TEST(PlotScale, TickLabelsHaveTheDecimalsTheStepNeeds) {
  EXPECT_EQ(formatTick(0.25, 0.25), "0.25");
  EXPECT_EQ(formatTick(0.5, 0.25), "0.50");
  EXPECT_EQ(formatTick(10, 5), "10");
  EXPECT_EQ(formatTick(0.30000000000000004, 0.1), "0.3");
  EXPECT_EQ(formatTick(-1e-17, 0.1), "0.0");  // never "-0.0"
  EXPECT_EQ(formatTick(-0.2, 0.1), "-0.2");
  EXPECT_EQ(formatTick(2500, 500), "2500");
  EXPECT_EQ(formatTick(0.002, 0.001), "0.002");
}

TEST(PlotScale, LinearScaleMapsEndsAndMiddle) {
  const LinearScale y{0, 10, 300, 100};  // SVG y: data up is pixels down
  EXPECT_DOUBLE_EQ(y(0), 300);
  EXPECT_DOUBLE_EQ(y(10), 100);
  EXPECT_DOUBLE_EQ(y(5), 200);
  EXPECT_DOUBLE_EQ(y(-5), 400);  // outside: extrapolated (the plot clips it)
  const LinearScale x{-1, 1, 80, 880};
  EXPECT_DOUBLE_EQ(x(0), 480);
}

}  // namespace
}  // namespace desslam::plot
