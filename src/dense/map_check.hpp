// Map consistency check: does a later keyframe see THROUGH a map point? A point left by a
// moving person (a "ghost") sits in space that the camera later observes as empty: the depth
// measured along the point's ray is well beyond the point.
#pragma once

#include <vector>

#include "core/camera.hpp"
#include "core/types.hpp"
#include "dense/dense_keyframe.hpp"

namespace desslam::dense {

struct MapCheckResult {
  size_t checked = 0;     // points seen (projected with a valid depth reading) by >= 1 later keyframe
  size_t violations = 0;  // checked points that some later keyframe sees through
  double share() const { return checked == 0 ? 0.0 : static_cast<double>(violations) / checked; }
};

struct MapCheckOptions {
  double tolerance = 0.05;  // metres the observed depth may lie beyond the point
  // Seen through only if EVERY valid reading in the (2r+1)^2 window around the projected pixel
  // lies beyond the point: a point on a silhouette, misprojected by a pixel or two, would
  // otherwise "see" the background next to it. 0 = the nearest pixel alone.
  int window_radius_px = 1;
};

// For each point (points_w[i], made from a keyframe at source_times[i]) and each keyframe k with
// timestamp > source_times[i]: project into k (pose k.T_w_c, distortion applied to find the raw
// pixel, nearest pixel); if the point is in front of the camera, inside the image and k has a
// valid depth reading (> 0) in the window, the point is checked; it is a violation when the
// readings there exceed the point's depth along the ray by more than options.tolerance (see
// MapCheckOptions). Each point counts once. Keyframes' exclude masks are not consulted: a person
// in front yields a smaller depth, never a violation. Throws InputError when the two point
// vectors differ in length or a keyframe's depth is not CV_32F of the camera's size.
MapCheckResult freeSpaceViolations(const std::vector<Vec3>& points_w, const std::vector<Timestamp>& source_times,
                                   const std::vector<DenseKeyframe>& keyframes, const PinholeCamera& camera,
                                   const MapCheckOptions& options = {});

// Same, for the per-keyframe clouds of a DenseMap (DenseMap::worldScans): each point's source
// time is its scan's timestamp.
MapCheckResult freeSpaceViolations(const std::vector<WorldScan>& scans, const std::vector<DenseKeyframe>& keyframes,
                                   const PinholeCamera& camera, const MapCheckOptions& options = {});

}  // namespace desslam::dense
