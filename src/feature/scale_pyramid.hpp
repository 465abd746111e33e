// Scale factors of an image pyramid: level l is the image shrunk by scale[l] = factor^l.
// Plain data shared (read-only) by frames, keyframes and map points.
#pragma once

#include <vector>

namespace desslam::feature {

struct ScalePyramid {
  std::vector<double> scale, inv_scale;    // factor^l and its inverse, per level
  std::vector<double> sigma2, inv_sigma2;  // scale^2: variance of a keypoint position at level l
  double scale_factor = 1.0;               // factor between consecutive levels
  double log_scale_factor = 0.0;           // log(scale_factor), for predicting a level from distance

  int levels() const { return static_cast<int>(scale.size()); }
};

// Throws desslam::ConfigError (naming orb.num_levels / orb.scale_factor) on bad values.
ScalePyramid makeScalePyramid(int num_levels, double scale_factor);

}  // namespace desslam::feature
