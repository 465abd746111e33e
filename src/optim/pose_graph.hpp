// Pose-graph optimisation over SE(3) (loop closing's essential graph): nodes are keyframe poses,
// edges relative poses measured before the loop was found (spanning tree, strong covisibility)
// or by the loop itself. RGB-D makes scale observable, so there is no Sim(3) scale here.
// Plain data in and out; the caller copies poses from and back to its map.
#pragma once

#include <vector>

#include "core/se3.hpp"

namespace desslam::optim {

struct PoseGraphNode {
  SE3 T_w_c;           // in: initial estimate, out: optimised (unchanged when fixed)
  bool fixed = false;  // held constant; at least one node should be (the gauge)
};

struct PoseGraphEdge {
  int from = -1, to = -1;  // node indices
  SE3 T_from_to;           // measured relative pose: T_w_from^-1 * T_w_to
  double weight = 1.0;     // information scale of the whole 6-D residual (> 0)
};

struct PoseGraphOptions {
  int iterations = 20;            // Levenberg-Marquardt iterations
  // Information of the rotation residual relative to the translation one (radians vs metres):
  // 1 treats 1 rad like 1 m, which keeps the rotations of a drifting loop as the odometry had them.
  double rotation_weight = 1.0;
  int threads = 1;

  void validate() const;  // throws ConfigError naming "pose_graph.<key>"
};

struct PoseGraphSummary {
  double initial_cost = 0;
  double final_cost = 0;
  int iterations = 0;
  bool usable = false;  // Ceres produced a usable solution (poses were written)
};

// Minimises sum_e weight_e * |r_e|^2 with r_e = [R_m^T (t_est - t_m); 2 vec(q_m^-1 q_est)] for
// T_est = T_w_from^-1 T_w_to against the measurement T_m (translation first). Rotations move on the
// quaternion manifold (ceres::EigenQuaternionManifold). With no fixed node the first is fixed.
// Throws InputError for an edge index out of range, a self edge or a non-positive weight.
PoseGraphSummary optimizePoseGraph(std::vector<PoseGraphNode>& nodes, const std::vector<PoseGraphEdge>& edges,
                                   const PoseGraphOptions& options = {});

}  // namespace desslam::optim
