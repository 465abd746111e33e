// Pose-graph optimisation on a constructed loop: 40 poses on a circle, odometry with a bias
// (drift) and noise, one loop edge back to the start.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "optim/pose_graph.hpp"

namespace desslam::optim {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<SE3> circle(int n, double radius) {
  std::vector<SE3> poses;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * kPi * i / n;
    // Camera looking outwards, tilted a little up and down along the way.
    const Quat q = Quat(Eigen::AngleAxisd(a, Vec3::UnitZ())) * Quat(Eigen::AngleAxisd(0.2 * std::sin(2 * a), Vec3::UnitX()));
    poses.emplace_back(q, Vec3(radius * std::cos(a), radius * std::sin(a), 0.3 * std::sin(a)));
  }
  return poses;
}

double rmse(const std::vector<PoseGraphNode>& nodes, const std::vector<SE3>& truth) {
  double sum = 0;
  for (size_t i = 0; i < nodes.size(); ++i) sum += (nodes[i].T_w_c.translation() - truth[i].translation()).squaredNorm();
  return std::sqrt(sum / nodes.size());
}

TEST(PoseGraph, LoopEdgeCorrectsAccumulatedDrift) {
  constexpr int kPoses = 40;
  const std::vector<SE3> truth = circle(kPoses, 2.0);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 1.0);
  // Biased odometry: every step turns 0.5 deg too far and overshoots 1 cm, plus noise.
  const SE3 bias(Quat(Eigen::AngleAxisd(0.5 * kPi / 180, Vec3(0.2, 0.1, 1.0).normalized())), Vec3(0.01, 0.0, 0.002));
  std::vector<PoseGraphEdge> edges;
  std::vector<PoseGraphNode> nodes(kPoses);
  nodes[0].T_w_c = truth[0];
  nodes[0].fixed = true;
  for (int i = 1; i < kPoses; ++i) {
    const Vec6 xi = (Vec6() << 0.002 * noise(rng), 0.002 * noise(rng), 0.002 * noise(rng), 0.001 * noise(rng),
                     0.001 * noise(rng), 0.001 * noise(rng)).finished();
    const SE3 measured = truth[i - 1].inverse() * truth[i] * bias * SE3::exp(xi);
    edges.push_back({i - 1, i, measured, 1.0});
    nodes[i].T_w_c = nodes[i - 1].T_w_c * measured;  // dead reckoning
  }
  // The loop: the last pose seen again from the first, measured well (as 3-D-3-D RANSAC would).
  edges.push_back({kPoses - 1, 0, truth[kPoses - 1].inverse() * truth[0], 1.0});

  const double before = rmse(nodes, truth);
  const PoseGraphSummary summary = optimizePoseGraph(nodes, edges, PoseGraphOptions{});
  const double after = rmse(nodes, truth);
  std::printf("pose graph: RMSE %.3f m -> %.3f m (cost %.4g -> %.4g, %d iterations)\n", before, after,
              summary.initial_cost, summary.final_cost, summary.iterations);
  ASSERT_TRUE(summary.usable);
  EXPECT_GT(before, 0.2) << "the constructed drift must be large enough to matter";
  EXPECT_LT(after * 3, before);
  EXPECT_LT(summary.final_cost, summary.initial_cost);
  // The fixed node does not move.
  EXPECT_LT((nodes[0].T_w_c.translation() - truth[0].translation()).norm(), 1e-12);
}

TEST(PoseGraph, ConsistentGraphStaysPut) {
  const std::vector<SE3> truth = circle(10, 1.0);
  std::vector<PoseGraphNode> nodes;
  for (const SE3& T : truth) nodes.push_back({T, false});
  std::vector<PoseGraphEdge> edges;
  for (int i = 0; i < 10; ++i) edges.push_back({i, (i + 1) % 10, truth[i].inverse() * truth[(i + 1) % 10], 1.0});
  const PoseGraphSummary summary = optimizePoseGraph(nodes, edges);  // no node fixed: the first is
  ASSERT_TRUE(summary.usable);
  EXPECT_LT(rmse(nodes, truth), 1e-9);
}

TEST(PoseGraph, RejectsBadEdges) {
  std::vector<PoseGraphNode> nodes(3);
  EXPECT_THROW(optimizePoseGraph(nodes, {{0, 3, SE3(), 1.0}}), InputError);
  EXPECT_THROW(optimizePoseGraph(nodes, {{1, 1, SE3(), 1.0}}), InputError);
  EXPECT_THROW(optimizePoseGraph(nodes, {{0, 1, SE3(), 0.0}}), InputError);
  PoseGraphOptions options;
  options.iterations = 0;
  EXPECT_THROW(optimizePoseGraph(nodes, {{0, 1, SE3(), 1.0}}, options), ConfigError);
}

}  // namespace
}  // namespace desslam::optim
