// Pose-only optimisation of a frame on its current matches, shared by tracking and
// relocalisation.
#pragma once

#include "core/camera.hpp"
#include "map/frame.hpp"
#include "map/map.hpp"

namespace desslam::tracking {

// Optimises frame.T_c_w on frame.matches (map points, and visual-odometry points where a match
// has one) with optim::optimizePose; matches to points gone bad and outliers are cleared.
// Returns the map-point inliers (0 with fewer than 6 matches, pose untouched). bf: virtual
// stereo baseline times fx for the depth residual. Takes map.mutex() shared while reading the
// points; call it without holding the lock.
int optimizeFramePose(map::Frame& frame, const map::Map& map, const PinholeCamera& camera, double bf);

}  // namespace desslam::tracking
