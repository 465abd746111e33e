// Bundle adjustment over keyframe poses and points (local BA in mapping, global BA in loop
// closing). Plain data in and out; callers copy from and back to their map.
#pragma once

#include <atomic>
#include <vector>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "optim/observation.hpp"

namespace desslam::optim {

struct BaKeyframe {
  SE3 T_c_w;
  bool fixed = false;  // held constant (at least one should be, to fix the gauge)
};

struct BaPoint {
  Vec3 p_w = Vec3::Zero();
};

struct BaObservation {
  int keyframe = -1;  // index into the keyframes vector
  int point = -1;     // index into the points vector
  Observation obs;
  bool outlier = false;  // output (input value is ignored)
};

struct BundleAdjustmentOptions {
  double bf = 40.0;          // virtual stereo baseline times fx (pixel * metres)
  int iterations = 10;       // Levenberg-Marquardt iterations per pass
  double chi2_mono = 5.991;  // 95% chi2, 2 dof
  double chi2_rgbd = 7.815;  // 95% chi2, 3 dof
  bool second_pass_without_outliers = true;
  int threads = 1;           // Ceres threads (local mapping shares the CPU with tracking)

  static constexpr const char* kSection = "bundle_adjustment";
  template <class V> void fields(V& v) {
    v("bf", bf); v("iterations", iterations); v("chi2_mono", chi2_mono); v("chi2_rgbd", chi2_rgbd);
    v("second_pass_without_outliers", second_pass_without_outliers); v("threads", threads);
  }
  void validate() const;  // throws ConfigError naming the key
};

// Refines the non-fixed keyframe poses and every observed point in place.
// Pass 1 uses all observations with a Huber kernel (delta = sqrt(chi2 threshold)); observations
// whose chi2 then exceeds the threshold (or whose point is behind the camera) are flagged
// outlier. The optional pass 2 runs without them and without the kernel. Flags are finally
// re-evaluated at the returned estimate, so they describe it. Points with no observation are
// left as they are.
// `abort` (may be null) is polled every iteration (local mapping sets it when a new keyframe
// arrives): the solve stops, the estimate reached so far (every accepted step lowered the cost)
// is written back with its outlier flags, pass 2 is skipped, and the function returns false.
// Throws InputError for an index out of range or a bad inv_sigma2, ConfigError for bad options.
bool bundleAdjust(const PinholeCamera& camera, std::vector<BaKeyframe>& keyframes, std::vector<BaPoint>& points,
                  std::vector<BaObservation>& observations, const BundleAdjustmentOptions& options = {},
                  const std::atomic<bool>* abort = nullptr);

}  // namespace desslam::optim
