#include "tracking/frame_pose.hpp"

#include <mutex>
#include <shared_mutex>
#include <vector>

#include "optim/pose_optimizer.hpp"

namespace desslam::tracking {

namespace {
// Drops the visual-odometry matches that disagree with the pose of the map points alone (see the
// header); `observations` and `feature_of` lose them too. Leaves everything as it is when the
// map points give no pose with min_map_inliers inliers.
void dropVoPointsTheMapContradicts(map::Frame& frame, const PinholeCamera& camera, const optim::PoseOptimizerOptions& po,
                                   int min_map_inliers, std::vector<optim::PoseObservation>& observations,
                                   std::vector<int>& feature_of) {
  std::vector<optim::PoseObservation> map_only, vo_only;
  for (size_t k = 0; k < observations.size(); ++k)
    (frame.matches[feature_of[k]].point != nullptr ? map_only : vo_only).push_back(observations[k]);
  if (vo_only.empty() || static_cast<int>(map_only.size()) < min_map_inliers) return;
  SE3 T_c_w = frame.T_c_w;
  if (optim::optimizePose(camera, T_c_w, map_only, po) < min_map_inliers) return;
  optim::classifyPoseObservations(camera, T_c_w, vo_only, po);
  std::vector<optim::PoseObservation> kept;
  std::vector<int> kept_feature;
  size_t vo = 0;
  for (size_t k = 0; k < observations.size(); ++k) {
    map::FeatureMatch& m = frame.matches[feature_of[k]];
    if (m.point == nullptr && vo_only[vo++].outlier) {
      m = {};
      continue;
    }
    kept.push_back(observations[k]);
    kept_feature.push_back(feature_of[k]);
  }
  observations = std::move(kept);
  feature_of = std::move(kept_feature);
  frame.T_c_w = T_c_w;  // the joint optimisation starts from the map's pose
}
}  // namespace

int optimizeFramePose(map::Frame& frame, const map::Map& map, const PinholeCamera& camera, double bf,
                      int vo_check_min_map_inliers) {
  const map::FeatureSet& features = *frame.features;
  const auto& pyramid = *features.pyramid;
  std::vector<optim::PoseObservation> observations;
  std::vector<int> feature_of;
  {
    std::shared_lock lock(map.mutex());
    for (size_t i = 0; i < features.size(); ++i) {
      map::FeatureMatch& m = frame.matches[i];
      if (!m.matched()) continue;
      if (m.point != nullptr && m.point->bad) {
        m = {};
        continue;
      }
      optim::PoseObservation o;
      o.obs.uv = features.uv[i];
      o.obs.depth = features.hasDepth(i) ? features.depth[i] : -1.0;
      o.obs.inv_sigma2 = pyramid.inv_sigma2[features.level(i)];
      o.point_w = m.point != nullptr ? m.point->position : m.vo_point;
      observations.push_back(o);
      feature_of.push_back(static_cast<int>(i));
    }
  }
  if (observations.size() < 6) return 0;
  optim::PoseOptimizerOptions po;
  po.bf = bf;
  if (vo_check_min_map_inliers > 0)
    dropVoPointsTheMapContradicts(frame, camera, po, vo_check_min_map_inliers, observations, feature_of);
  optim::optimizePose(camera, frame.T_c_w, observations, po);
  int map_inliers = 0;
  for (size_t k = 0; k < observations.size(); ++k) {
    map::FeatureMatch& m = frame.matches[feature_of[k]];
    if (observations[k].outlier) {
      m = {};
    } else if (m.point != nullptr) {
      ++map_inliers;
    }
  }
  return map_inliers;
}

}  // namespace desslam::tracking
