// Rigid SE(3) from 3-D-3-D correspondences with RANSAC: the loop closer's relative pose between
// the current keyframe's depth-backed points and the loop keyframe's map points. Depth makes the
// scale observable, so there is no Sim(3) scale. Minimal sets of 3, closed-form fit (Umeyama /
// Horn, eval::alignRigid), refinement on all inliers.
#pragma once

#include <cstdint>
#include <vector>

#include "core/se3.hpp"

namespace desslam::loop {

struct PointCorrespondence {
  Vec3 p_a;            // a point in frame a (target)
  Vec3 p_b;            // the same point in frame b (source)
  double depth = 1.0;  // sensor depth (metres) behind the noisier of the two; scales its tolerance
};

struct RigidRansacOptions {
  int iterations = 300;
  // Inlier distance |p_a - T_a_b p_b| at 1 m depth; a correspondence at depth z accepts
  // threshold_m * max(1, z^2) (structured-light depth noise grows with z^2).
  double threshold_m = 0.02;
  int min_inliers = 20;
  uint64_t seed = 1;  // same inputs + seed => same result

  void validate() const;  // throws ConfigError naming "rigid_ransac.<key>"
};

struct RigidRansacResult {
  bool success = false;        // >= min_inliers inliers after refinement
  SE3 T_a_b;                   // p_a = T_a_b * p_b
  std::vector<bool> inliers;   // per correspondence, for T_a_b
  int inlier_count = 0;
  double rmse_m = 0;           // over the inliers
};

// Tolerance of one correspondence under `options` (metres).
double inlierThreshold(const PointCorrespondence& c, const RigidRansacOptions& options);

// Samples minimal sets of 3 non-collinear correspondences, keeps the hypothesis with the most
// inliers, then alternates a least-squares fit on the inliers and re-classification until the
// inlier set settles. Fewer than 3 correspondences => success = false.
RigidRansacResult estimateRigidRansac(const std::vector<PointCorrespondence>& correspondences,
                                      const RigidRansacOptions& options);

}  // namespace desslam::loop
