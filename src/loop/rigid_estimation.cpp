#include "loop/rigid_estimation.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "core/option_fields.hpp"
#include "eval/alignment.hpp"

namespace desslam::loop {

namespace {

// Triangles thinner than this (twice their area, m^2) do not fix a rotation well enough to vote.
constexpr double kMinTriangleArea2 = 1e-4;
constexpr int kMaxRefinements = 10;
constexpr int kSampleAttempts = 20;  // draws per iteration to find a non-degenerate triple

SE3 fit(const std::vector<PointCorrespondence>& c, const std::vector<int>& indices) {
  std::vector<Vec3> a, b;
  a.reserve(indices.size());
  b.reserve(indices.size());
  for (int i : indices) {
    a.push_back(c[i].p_a);
    b.push_back(c[i].p_b);
  }
  return eval::alignRigid(b, a, eval::DegenerateInput::kAnyMinimiser);  // T_a_b: b -> a
}

int classify(const std::vector<PointCorrespondence>& c, const SE3& T_a_b, const RigidRansacOptions& options,
             std::vector<bool>& inliers, double& sum_sq) {
  inliers.assign(c.size(), false);
  sum_sq = 0;
  int count = 0;
  for (size_t i = 0; i < c.size(); ++i) {
    const double d = (c[i].p_a - T_a_b * c[i].p_b).norm();
    if (d <= inlierThreshold(c[i], options)) {
      inliers[i] = true;
      sum_sq += d * d;
      ++count;
    }
  }
  return count;
}

}  // namespace

void RigidRansacOptions::validate() const {
  requireInRange("rigid_ransac", "iterations", iterations, 1, 1000000);
  requireInRange("rigid_ransac", "threshold_m", threshold_m, 1e-6, 10.0);
  requireInRange("rigid_ransac", "min_inliers", min_inliers, 3, 1000000);
}

double inlierThreshold(const PointCorrespondence& c, const RigidRansacOptions& options) {
  const double z = std::max(1.0, c.depth);
  return options.threshold_m * z * z;
}

RigidRansacResult estimateRigidRansac(const std::vector<PointCorrespondence>& correspondences,
                                      const RigidRansacOptions& options) {
  options.validate();
  RigidRansacResult result;
  const int n = static_cast<int>(correspondences.size());
  result.inliers.assign(correspondences.size(), false);
  if (n < 3) return result;

  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  int best_count = -1;
  double best_sq = 0;
  SE3 best;
  std::vector<bool> inliers;
  for (int it = 0; it < options.iterations; ++it) {
    int i0 = 0, i1 = 0, i2 = 0;
    bool found = false;
    for (int attempt = 0; attempt < kSampleAttempts && !found; ++attempt) {
      i0 = pick(rng);
      i1 = pick(rng);
      i2 = pick(rng);
      if (i0 == i1 || i1 == i2 || i0 == i2) continue;
      const Vec3& b0 = correspondences[i0].p_b;
      const double area_b = (correspondences[i1].p_b - b0).cross(correspondences[i2].p_b - b0).norm();
      const Vec3& a0 = correspondences[i0].p_a;
      const double area_a = (correspondences[i1].p_a - a0).cross(correspondences[i2].p_a - a0).norm();
      found = area_a > kMinTriangleArea2 && area_b > kMinTriangleArea2;
    }
    if (!found) continue;
    const SE3 T = fit(correspondences, {i0, i1, i2});
    double sq = 0;
    const int count = classify(correspondences, T, options, inliers, sq);
    if (count > best_count || (count == best_count && sq < best_sq)) {
      best_count = count;
      best_sq = sq;
      best = T;
    }
  }
  if (best_count < 3) return result;

  // Least squares on the inliers, re-classify, until the set stops changing.
  SE3 T = best;
  std::vector<bool> current;
  double sq = 0;
  int count = classify(correspondences, T, options, current, sq);
  for (int r = 0; r < kMaxRefinements && count >= 3; ++r) {
    std::vector<int> indices;
    for (int i = 0; i < n; ++i)
      if (current[i]) indices.push_back(i);
    const SE3 refined = fit(correspondences, indices);
    std::vector<bool> next;
    double next_sq = 0;
    const int next_count = classify(correspondences, refined, options, next, next_sq);
    if (next_count < count) break;  // refinement must not lose support
    const bool settled = next == current;
    T = refined;
    current.swap(next);
    count = next_count;
    sq = next_sq;
    if (settled) break;
  }
  result.T_a_b = T;
  result.inliers = current;
  result.inlier_count = count;
  result.rmse_m = count > 0 ? std::sqrt(sq / count) : 0;
  result.success = count >= options.min_inliers;
  return result;
}

}  // namespace desslam::loop
