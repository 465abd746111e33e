#include <gtest/gtest.h>

#include "core/error.hpp"
#include "eval/association.hpp"

namespace desslam::eval {
namespace {

Trajectory atTimes(const std::vector<double>& times) {
  Trajectory t;
  for (const double s : times) t.push_back({s, SE3()});
  return t;
}

std::vector<std::pair<std::size_t, std::size_t>> pairsOf(const std::vector<Match>& matches) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (const Match& m : matches) out.emplace_back(m.gt_index, m.est_index);
  return out;
}

using Pairs = std::vector<std::pair<std::size_t, std::size_t>>;

TEST(EvalAssociate, PairsJitteredTimestampsOneToOne) {
  // Ground truth at 100 Hz, estimate at ~30 Hz with a few milliseconds of jitter.
  std::vector<double> gt_times;
  for (int k = 0; k < 100; ++k) gt_times.push_back(1305031101.0 + 0.01 * k);
  const Trajectory gt = atTimes(gt_times);
  const Trajectory est = atTimes({1305031101.0031, 1305031101.0339, 1305031101.0672, 1305031101.1004});
  const auto matches = associate(gt, est, 0.02);
  EXPECT_EQ(pairsOf(matches), (Pairs{{0, 0}, {3, 1}, {7, 2}, {10, 3}}));
}

TEST(EvalAssociate, GreedyTakesSmallestDifferenceFirst) {
  // est 0 (t=1.000) is 0.004 from gt 0 and 0.010 from gt 1; est 1 (t=1.009) is 0.001 from gt 1.
  // Greedy by difference: (gt1, est1) first, then (gt0, est0).
  const Trajectory gt = atTimes({0.996, 1.010});
  const Trajectory est = atTimes({1.000, 1.009});
  EXPECT_EQ(pairsOf(associate(gt, est, 0.02)), (Pairs{{0, 0}, {1, 1}}));
  // With one ground-truth pose both estimates compete; the closer one wins, the other is unmatched.
  EXPECT_EQ(pairsOf(associate(atTimes({1.010}), est, 0.02)), (Pairs{{0, 1}}));
}

TEST(EvalAssociate, MissingPosesStayUnmatched) {
  const Trajectory gt = atTimes({1.0, 2.0, 3.0, 4.0});
  const Trajectory est = atTimes({1.001, 2.5, 4.002});  // 2.5 has no ground truth nearby
  EXPECT_EQ(pairsOf(associate(gt, est, 0.02)), (Pairs{{0, 0}, {3, 2}}));
}

TEST(EvalAssociate, DuplicateTimestampsUseTheLastPose) {
  const Trajectory gt = atTimes({1.0, 2.0, 2.0, 3.0});
  const Trajectory est = atTimes({1.0, 1.0, 2.0, 3.0});
  // gt index 1 and est index 0 are shadowed by later poses with the same timestamp.
  EXPECT_EQ(pairsOf(associate(gt, est, 0.02)), (Pairs{{0, 1}, {2, 2}, {3, 3}}));
}

TEST(EvalAssociate, MaxDtIsInclusiveAtRealTimestampMagnitudes) {
  const double t0 = 1305031101.6258;
  const Trajectory gt = atTimes({t0, t0 + 1.0});
  EXPECT_EQ(associate(gt, atTimes({t0 + 0.02, t0 + 1.0 - 0.02}), 0.02).size(), 2u);
  EXPECT_EQ(associate(gt, atTimes({t0 + 0.0201, t0 + 1.0 - 0.0201}), 0.02).size(), 0u);
  EXPECT_EQ(associate(gt, atTimes({t0}), 0.0).size(), 1u);
}

TEST(EvalAssociate, ResultIsSortedByEstimateTimeForUnsortedInput) {
  const Trajectory gt = atTimes({3.0, 1.0, 2.0});
  const Trajectory est = atTimes({2.0, 3.0, 1.0});
  EXPECT_EQ(pairsOf(associate(gt, est, 0.02)), (Pairs{{1, 2}, {2, 0}, {0, 1}}));
}

TEST(EvalAssociate, RejectsNegativeMaxDt) {
  EXPECT_THROW(associate(atTimes({1.0}), atTimes({1.0}), -0.1), InputError);
}

}  // namespace
}  // namespace desslam::eval
