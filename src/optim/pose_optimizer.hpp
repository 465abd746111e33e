// Pose-only optimisation (motion-only BA): refine one camera pose against fixed 3-D points.
#pragma once

#include <vector>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "optim/observation.hpp"

namespace desslam::optim {

struct PoseObservation {
  Observation obs;
  Vec3 point_w = Vec3::Zero();
  bool outlier = false;  // output: set by optimizePose (input value is ignored)
};

struct PoseOptimizerOptions {
  double bf = 40.0;         // virtual stereo baseline times fx (pixel * metres); TUM-like cameras ~40
  int rounds = 4;           // optimise / classify rounds
  int iterations = 10;      // Levenberg-Marquardt iterations per round
  double chi2_mono = 5.991;  // 95% chi2, 2 dof
  double chi2_rgbd = 7.815;  // 95% chi2, 3 dof

  static constexpr const char* kSection = "pose_optimizer";
  template <class V> void fields(V& v) {
    v("bf", bf); v("rounds", rounds); v("iterations", iterations);
    v("chi2_mono", chi2_mono); v("chi2_rgbd", chi2_rgbd);
  }
  void validate() const;  // throws ConfigError naming the key
};

// Optimises T_c_w (in/out) with the points fixed. Each round optimises with the current inliers,
// then classifies every observation (excluded ones too) by its chi2 against the threshold;
// outliers are left out of the next round. The Huber kernel (delta = sqrt(chi2 threshold)) is
// on in all rounds but the last. Returns the number of inliers; T_c_w is left unchanged when
// fewer than 3 observations could be used.
// Throws InputError for a non-positive or non-finite inv_sigma2, ConfigError for bad options.
int optimizePose(const PinholeCamera& camera, SE3& T_c_w, std::vector<PoseObservation>& observations,
                 const PoseOptimizerOptions& options = {});

// Flags every observation at the fixed pose T_c_w by its chi2 against the threshold, as each round
// of optimizePose does, without optimising. Returns the number of inliers.
int classifyPoseObservations(const PinholeCamera& camera, const SE3& T_c_w,
                             std::vector<PoseObservation>& observations, const PoseOptimizerOptions& options = {});

}  // namespace desslam::optim
