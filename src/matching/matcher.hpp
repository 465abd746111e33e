// Map-aware ORB matching: by projection (frame-to-frame, local map), by descriptor between two
// feature sets (reference keyframe, triangulation), and fusion of duplicated map points.
// Callers hold the Map lock as each function states; nothing here locks.
#pragma once

#include <functional>
#include <vector>

#include "core/camera.hpp"
#include "map/frame.hpp"
#include "map/map.hpp"
#include "matching/matcher_options.hpp"

namespace desslam::matching {

// A 3-D point to look for in a frame.
struct ProjectionCandidate {
  Vec3 p_w;
  const uint8_t* descriptor = nullptr;
  map::MapPoint* point = nullptr;  // null for a visual-odometry point
  int min_level = 0, max_level = 0;  // pyramid levels searched
  double radius = 0;                 // pixels at level 0
  float angle = -1;                  // keypoint angle (deg) of the source, < 0 if none
};

// Which of a frame's features a projection search may match.
struct ProjectionSearchScope {
  // Per feature, nonzero = may be matched. Null: the frame's usable (static) features.
  const std::vector<uint8_t>* eligible = nullptr;
  // > 0: a feature needs depth, and |1 - z_point / z_feature| at most this, where z_point is the
  // candidate's depth in the frame (the stage-1 residual against a map point instead of a frame).
  double max_relative_depth_residual = 0;
};

// Projects each candidate with frame.T_c_w and takes the closest descriptor among the frame's
// eligible (by default: usable), still unmatched features in the window. Writes frame.matches.
// Returns the count. Only reads candidates' precomputed data: no lock needed.
int searchByProjection(map::Frame& frame, const PinholeCamera& camera,
                       const std::vector<ProjectionCandidate>& candidates, const MatcherOptions& options,
                       const ProjectionSearchScope& scope = {});

// Brute-force matching of features `a_indices` of set a against `b_indices` of set b with a ratio
// test and mutual uniqueness; `accept(ia, ib)` may reject on geometry (e.g. epipolar).
// Returns pairs (ia, ib).
std::vector<std::pair<int, int>> matchDescriptors(const map::FeatureSet& a, const std::vector<int>& a_indices,
                                                  const map::FeatureSet& b, const std::vector<int>& b_indices,
                                                  int max_distance, double ratio, bool check_orientation,
                                                  const std::function<bool(int, int)>& accept = {});

// Projects `points` into keyframe kf and fuses duplicates: where the matching feature already
// has a point, the one with fewer observations is replaced by the other; else an observation is
// added. Features the keyframe marks dynamic are candidates too: a match with a point made
// elsewhere vouches for a feature stage 1 could not verify. Requires the Map lock held
// exclusively. Returns the number of points fused or added.
int fuseIntoKeyframe(map::Map& map, map::Keyframe* kf, const std::vector<map::MapPoint*>& points,
                     const PinholeCamera& camera, double radius, const MatcherOptions& options);

// Rotation-consistency filter: keeps matches whose keypoint angle differences fall in the three
// most populated 12-degree bins (a rigid motion rotates all features alike).
std::vector<bool> orientationConsistent(const std::vector<float>& angle_differences_deg);

}  // namespace desslam::matching
