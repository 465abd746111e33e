// Relocalisation: recovers the pose of a frame that tracking lost, without a motion prior.
//
// Candidates: keyframes from the keyframe database ranked by bag-of-words score (optionally by
// the accumulated score of their covisibility group). Per candidate: descriptor matching between
// the frame and the candidate's map points within shared vocabulary nodes (direct index), ratio
// test and rotation consistency; PnP-RANSAC on the points' world positions and the frame's
// undistorted keypoints; pose-only optimisation (with depth); guided search by projection of the
// candidate's and its covisible keyframes' points; re-optimisation. The first candidate reaching
// relocalisation.min_inliers wins.
#pragma once

#include <vector>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "map/frame.hpp"
#include "map/map.hpp"
#include "place/keyframe_database.hpp"
#include "tracking/tracking_options.hpp"

namespace desslam::tracking {

struct PnpResult {
  bool ok = false;            // at least options.min_pnp_inliers inliers
  SE3 T_c_w;
  std::vector<int> inliers;   // indices into the input correspondences
};

// PnP-RANSAC (OpenCV: EPnP on minimal sets, Levenberg-Marquardt refinement on the inliers) of
// world points and their undistorted pixels, with the camera's intrinsics and no distortion.
// Uses options.ransac_iterations, ransac_reprojection_px, ransac_confidence, min_pnp_inliers.
// Throws InputError when the two lists differ in length.
PnpResult solvePnpRansac(const std::vector<Vec3>& points_w, const std::vector<Vec2>& uv, const PinholeCamera& camera,
                         const RelocalisationOptions& options);

struct RelocalisationResult {
  bool success = false;
  map::Keyframe* keyframe = nullptr;  // the candidate that gave the pose (tracking's new reference)
  int candidates = 0;                 // candidates tried
  int inliers = 0;                    // map-point inliers of the final pose optimisation
  // Why an attempt failed (the best candidate's figures): descriptor matches, PnP-RANSAC inliers,
  // pose-optimisation inliers after the guided search (success needs relocalisation.min_inliers).
  int best_matches = 0, best_pnp_inliers = 0, best_inliers = 0;
};

class Relocaliser {
 public:
  // bf: virtual stereo baseline times fx (camera.bf(): camera.depth_baseline * camera.fx) for depth residuals.
  // Validates `options` (ConfigError naming relocalisation.<key>).
  Relocaliser(const RelocalisationOptions& options, const PinholeCamera& camera, map::Map& map,
              const place::KeyframeDatabase& database, double bf);

  // frame.features and frame.status set (only usable features are matched). On success writes
  // frame.T_c_w and frame.matches (map-point inliers only), ready for local-map tracking; on
  // failure clears frame.matches and leaves frame.T_c_w as it was.
  // only_map: candidates from this atlas map only (-1: every map).
  // Locks: takes Map::mutex() shared, in short sections; call it without holding the Map lock.
  RelocalisationResult relocalise(map::Frame& frame, int only_map = -1) const;

 private:
  std::vector<map::Keyframe*> candidates(const place::BowVector& bow, int only_map) const;
  // Descriptor matches (frame feature, map point) within shared vocabulary nodes.
  std::vector<std::pair<int, map::MapPoint*>> matchByNodes(const map::Frame& frame,
                                                           const place::FeatureVector& frame_nodes,
                                                           map::Keyframe* keyframe) const;
  // Guided search for the candidate's and its covisible keyframes' points not matched yet.
  int searchCovisiblePoints(map::Frame& frame, map::Keyframe* keyframe, double radius_px) const;
  // Pose-only optimisation of frame.T_c_w on its matches; clears outliers. Returns inliers.
  int optimizePose(map::Frame& frame) const;

  RelocalisationOptions options_;
  PinholeCamera camera_;
  map::Map& map_;
  const place::KeyframeDatabase& database_;
  double bf_;
};

}  // namespace desslam::tracking
