#include "tracking/frame_pose.hpp"

#include <mutex>
#include <shared_mutex>
#include <vector>

#include "optim/pose_optimizer.hpp"

namespace desslam::tracking {

int optimizeFramePose(map::Frame& frame, const map::Map& map, const PinholeCamera& camera, double bf) {
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
