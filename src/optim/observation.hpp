// What the optimisers see of a keypoint measurement: plain data, no map types, so tracking,
// local mapping and loop closing can all feed them.
#pragma once

#include "core/types.hpp"

namespace desslam::optim {

struct Observation {
  Vec2 uv = Vec2::Zero();   // undistorted pixel
  double depth = -1;        // metres; <= 0 means no depth (monocular residual)
  double inv_sigma2 = 1.0;  // 1 / sigma^2 of the keypoint's pyramid level (sigma = scale factor^level)

  bool hasDepth() const { return depth > 0; }
};

}  // namespace desslam::optim
