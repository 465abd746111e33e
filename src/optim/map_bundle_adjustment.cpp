#include "optim/map_bundle_adjustment.hpp"

#include <chrono>
#include <map>
#include <mutex>
#include <shared_mutex>

namespace desslam::optim {

MapBaProblem buildMapBaProblem(const std::vector<map::Keyframe*>& keyframes, const std::vector<bool>& fixed) {
  MapBaProblem problem;
  std::map<uint64_t, int> kf_index;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    if (keyframes[i]->bad || kf_index.count(keyframes[i]->id) != 0) continue;
    kf_index[keyframes[i]->id] = static_cast<int>(problem.keyframes.size());
    problem.keyframes.push_back(keyframes[i]);
    problem.ba_keyframes.push_back({keyframes[i]->T_c_w, fixed[i]});
  }
  std::map<uint64_t, map::MapPoint*> unique_points;  // by id: a deterministic order
  for (size_t i = 0; i < problem.keyframes.size(); ++i) {
    if (problem.ba_keyframes[i].fixed) continue;
    for (map::MapPoint* p : problem.keyframes[i]->points)
      if (p != nullptr && !p->bad) unique_points.emplace(p->id, p);
  }
  for (auto& [pid, p] : unique_points) {
    const int point_index = static_cast<int>(problem.points.size());
    problem.points.push_back(p);
    problem.ba_points.push_back({p->position});
    for (auto& [kid, obs] : p->observations) {
      auto it = kf_index.find(kid);
      if (it == kf_index.end()) continue;
      const map::FeatureSet& f = *obs.first->features;
      const int i = obs.second;
      BaObservation o;
      o.keyframe = it->second;
      o.point = point_index;
      o.obs.uv = f.uv[i];
      o.obs.depth = f.hasDepth(i) ? f.depth[i] : -1.0;
      o.obs.inv_sigma2 = f.pyramid->inv_sigma2[f.level(i)];
      problem.ba_observations.push_back(o);
    }
  }
  return problem;
}

void applyMapBaResult(map::Map& map, const MapBaProblem& problem) {
  for (const BaObservation& o : problem.ba_observations) {
    if (!o.outlier) continue;
    map::MapPoint* p = problem.points[o.point];
    map::Keyframe* k = problem.keyframes[o.keyframe];
    if (!p->bad) map::eraseObservation(map, p, k);
  }
  for (size_t i = 0; i < problem.keyframes.size(); ++i)
    if (!problem.ba_keyframes[i].fixed && !problem.keyframes[i]->bad)
      problem.keyframes[i]->T_c_w = problem.ba_keyframes[i].T_c_w;
  for (size_t i = 0; i < problem.points.size(); ++i) {
    if (problem.points[i]->bad) continue;
    problem.points[i]->position = problem.ba_points[i].p_w;
    map::updateNormalAndDepth(problem.points[i]);
  }
}

GlobalBaResult globalBundleAdjustment(map::Map& map, const PinholeCamera& camera,
                                      const BundleAdjustmentOptions& options, const std::atomic<bool>* abort) {
  const auto start = std::chrono::steady_clock::now();
  GlobalBaResult result;
  MapBaProblem problem;
  {
    std::shared_lock lock(map.mutex());
    const std::vector<map::Keyframe*> keyframes = map.keyframes();
    // Each map of the atlas holds its own gauge: its origin keyframe stays fixed, as do the
    // keyframes held where tracking put them (map::globalBaFixed).
    const std::vector<bool> fixed = map::globalBaFixed(keyframes);
    problem = buildMapBaProblem(keyframes, fixed);
  }
  if (problem.keyframes.size() < 2) return result;
  result.completed = bundleAdjust(camera, problem.ba_keyframes, problem.ba_points,
                                         problem.ba_observations, options, abort);
  {
    std::unique_lock lock(map.mutex());
    applyMapBaResult(map, problem);
  }
  result.keyframes = problem.keyframes.size();
  result.points = problem.points.size();
  result.observations = problem.ba_observations.size();
  for (const auto& o : problem.ba_observations) result.outliers += o.outlier ? 1 : 0;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace desslam::optim
