#include <algorithm>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "feature/keypoint_distribution.hpp"

namespace desslam::feature {
namespace {

cv::KeyPoint at(float x, float y, float response) { return cv::KeyPoint(x, y, 7.f, -1.f, response); }

TEST(DistributeKeypoints, IsolatedWeakKeypointsSurviveADenseStrongCluster) {
  std::vector<cv::KeyPoint> candidates;
  cv::RNG rng(3);
  for (int i = 0; i < 2000; ++i)  // strong cluster in the top-left 100x100
    candidates.push_back(at(rng.uniform(0.f, 100.f), rng.uniform(0.f, 100.f), rng.uniform(50.f, 100.f)));
  std::vector<int> isolated;
  for (int i = 0; i < 10; ++i) {  // weak corners spread along the bottom
    isolated.push_back(static_cast<int>(candidates.size()));
    candidates.push_back(at(30.f + 60.f * i, 450.f, 1.f));
  }
  const std::vector<int> picked = distributeKeypoints(candidates, cv::Rect2f(0, 0, 640, 480), 60);
  EXPECT_EQ(picked.size(), 60u);
  const std::set<int> picked_set(picked.begin(), picked.end());
  EXPECT_EQ(picked_set.size(), picked.size()) << "an index was picked twice";
  for (int i : isolated) EXPECT_TRUE(picked_set.count(i)) << "isolated keypoint " << i << " was dropped";
}

TEST(DistributeKeypoints, KeepsTheStrongestOfNeighbours) {
  const std::vector<cv::KeyPoint> candidates{at(10, 10, 5), at(11, 10, 9), at(10, 11, 2), at(300, 300, 1)};
  const std::vector<int> picked = distributeKeypoints(candidates, cv::Rect2f(0, 0, 640, 480), 2);
  ASSERT_EQ(picked.size(), 2u);
  EXPECT_TRUE(std::count(picked.begin(), picked.end(), 1));
  EXPECT_TRUE(std::count(picked.begin(), picked.end(), 3));
}

TEST(DistributeKeypoints, ReturnsAllWhenFewerThanWantedAndIgnoresOutsideRegion) {
  const std::vector<cv::KeyPoint> candidates{at(50, 50, 1), at(5, 5, 1), at(60, 90, 1), at(99, 99, 1),
                                             at(100, 50, 1)};  // (5,5) and (100,50) are outside
  std::vector<int> picked = distributeKeypoints(candidates, cv::Rect2f(10, 10, 90, 90), 10);
  std::sort(picked.begin(), picked.end());
  EXPECT_EQ(picked, (std::vector<int>{0, 2, 3}));
  EXPECT_TRUE(distributeKeypoints(candidates, cv::Rect2f(10, 10, 90, 90), 0).empty());
  EXPECT_TRUE(distributeKeypoints({}, cv::Rect2f(10, 10, 90, 90), 10).empty());
}

TEST(DistributeKeypoints, CoincidentCornersTerminateAndYieldOne) {
  std::vector<cv::KeyPoint> candidates(50, at(20, 20, 1));
  candidates[17].response = 3;
  const std::vector<int> picked = distributeKeypoints(candidates, cv::Rect2f(0, 0, 64, 48), 10);
  ASSERT_EQ(picked.size(), 1u);
  EXPECT_EQ(picked[0], 17);
}

TEST(DistributeKeypoints, ExactCountOnUniformCandidatesAndDeterministic) {
  std::vector<cv::KeyPoint> candidates;
  cv::RNG rng(11);
  for (int i = 0; i < 5000; ++i)
    candidates.push_back(at(rng.uniform(0.f, 640.f), rng.uniform(0.f, 480.f), rng.uniform(0.f, 100.f)));
  const std::vector<int> a = distributeKeypoints(candidates, cv::Rect2f(0, 0, 640, 480), 777);
  const std::vector<int> b = distributeKeypoints(candidates, cv::Rect2f(0, 0, 640, 480), 777);
  EXPECT_EQ(a.size(), 777u);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace desslam::feature
