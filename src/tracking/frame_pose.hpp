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
//
// vo_check_min_map_inliers > 0: visual-odometry points must first agree with the pose the map
// points alone give, when those give one with at least that many inliers; the ones that do not
// are dropped (match cleared) before the joint optimisation. A VO point is the previous frame's
// depth at a feature, never seen from a second view: a walker the masks missed carries its points
// along, and a camera that holds still follows him (see tracking.vo_check_min_map_inliers).
int optimizeFramePose(map::Frame& frame, const map::Map& map, const PinholeCamera& camera, double bf,
                      int vo_check_min_map_inliers = 0);

}  // namespace desslam::tracking
