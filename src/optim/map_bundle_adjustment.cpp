#include "optim/map_bundle_adjustment.hpp"

#include <chrono>
#include <map>
#include <mutex>
#include <set>
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
    problem.centres_before.push_back(keyframes[i]->center());
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

namespace {

// Keyframe id -> its index in the problem.
std::map<uint64_t, size_t> keyframeIndex(const MapBaProblem& problem) {
  std::map<uint64_t, size_t> index;
  for (size_t i = 0; i < problem.keyframes.size(); ++i) index[problem.keyframes[i]->id] = i;
  return index;
}

// How far the solve moved keyframe i's camera centre.
Vec3 centreMove(const MapBaProblem& problem, size_t i) {
  return Vec3(problem.ba_keyframes[i].T_c_w.inverse().translation() - problem.centres_before[i]);
}

}  // namespace

std::vector<map::Keyframe*> weakKeyframesMovedFar(const MapBaProblem& problem, double max_move_m,
                                                  bool relative_to_parent) {
  const std::map<uint64_t, size_t> index = keyframeIndex(problem);
  std::vector<map::Keyframe*> far;
  for (size_t i = 0; i < problem.keyframes.size(); ++i) {
    const map::Keyframe* k = problem.keyframes[i];
    if (problem.ba_keyframes[i].fixed || !k->made_at_weak_pose || k->pose_held || k->bad) continue;
    Vec3 move = centreMove(problem, i);
    if (relative_to_parent && k->parent != nullptr)
      if (auto it = index.find(k->parent->id); it != index.end()) move -= centreMove(problem, it->second);
    if (move.norm() > max_move_m) far.push_back(problem.keyframes[i]);
  }
  return far;
}

std::vector<map::Keyframe*> keyframesMovedFar(const MapBaProblem& problem, double max_move_m) {
  const std::map<uint64_t, size_t> index = keyframeIndex(problem);
  std::vector<map::Keyframe*> far;
  for (size_t i = 0; i < problem.keyframes.size(); ++i) {
    const map::Keyframe* k = problem.keyframes[i];
    if (problem.ba_keyframes[i].fixed || k->made_at_weak_pose || k->pose_held || k->bad) continue;
    const Vec3 move = centreMove(problem, i);
    Vec3 from_parent = move;
    if (k->parent != nullptr)
      if (auto it = index.find(k->parent->id); it != index.end()) from_parent -= centreMove(problem, it->second);
    if (move.norm() > max_move_m && from_parent.norm() > max_move_m) far.push_back(problem.keyframes[i]);
  }
  return far;
}

std::vector<map::Keyframe*> looseGroupsMovedFar(const MapBaProblem& problem, double max_move_m) {
  const size_t n = problem.keyframes.size();
  const std::map<uint64_t, size_t> index = keyframeIndex(problem);
  // Groups: keyframes joined by enough shared points (union-find over the covisibility links).
  std::vector<size_t> group(n);
  for (size_t i = 0; i < n; ++i) group[i] = i;
  const auto root = [&](size_t i) {
    while (group[i] != i) i = group[i] = group[group[i]];
    return i;
  };
  for (size_t i = 0; i < n; ++i)
    for (const auto& [id, entry] : problem.keyframes[i]->connection_weights)
      if (auto it = index.find(id); it != index.end() && entry.second >= kMinGroupTiePoints)
        group[root(i)] = root(it->second);
  std::map<size_t, std::vector<size_t>> members;
  for (size_t i = 0; i < n; ++i) members[root(i)].push_back(i);
  std::vector<map::Keyframe*> far;
  for (const auto& [g, list] : members) {
    if (list.size() == n) break;  // one group: the map's own gauge holds it
    bool anchored = false, merged_in = true;
    Vec3 group_move = Vec3::Zero();
    for (size_t i : list) {
      const map::Keyframe* k = problem.keyframes[i];
      anchored = anchored || problem.ba_keyframes[i].fixed;
      merged_in = merged_in && k->made_in_map != k->map_id;
      group_move += centreMove(problem, i);
    }
    // A group of the map's own keyframes is placed by global BA, whatever ties it: there it
    // corrects drift (an fr1_xyz composite's first map lost 6.7 mm main-map ATE when held).
    if (anchored || !merged_in) continue;
    group_move /= static_cast<double>(list.size());
    // The distinct points tying the group to keyframes outside it, and where those keyframes went.
    std::set<const map::MapPoint*> ties;
    Vec3 outside_move = Vec3::Zero();
    int outside_views = 0;
    for (size_t i : list)
      for (const map::MapPoint* p : problem.keyframes[i]->points) {
        if (p == nullptr || p->bad || ties.count(p) != 0) continue;
        bool tie = false;
        for (const auto& [kid, obs] : p->observations)
          if (auto it = index.find(kid); it != index.end() && root(it->second) != g) {
            tie = true;
            outside_move += centreMove(problem, it->second);
            ++outside_views;
          }
        if (tie) ties.insert(p);
      }
    if (static_cast<int>(ties.size()) >= kMinGroupTiePoints) continue;
    if (outside_views > 0) outside_move /= static_cast<double>(outside_views);
    if ((group_move - outside_move).norm() <= max_move_m) continue;
    size_t oldest = list.front();
    for (size_t i : list)
      if (problem.keyframes[i]->id < problem.keyframes[oldest]->id) oldest = i;
    far.push_back(problem.keyframes[oldest]);
  }
  return far;
}

GlobalBaSolve solveGlobalBa(map::Map& map, const PinholeCamera& camera, const BundleAdjustmentOptions& options,
                            const std::atomic<bool>* abort) {
  GlobalBaSolve result;
  for (int attempt = 0; attempt < 2; ++attempt) {
    {
      std::shared_lock lock(map.mutex());
      const std::vector<map::Keyframe*> keyframes = map.keyframes();
      // Each map of the atlas holds its own gauge: its origin keyframe stays fixed, as do the
      // keyframes held where tracking put them (map::globalBaFixed).
      result.problem = buildMapBaProblem(keyframes, map::globalBaFixed(keyframes));
    }
    MapBaProblem& problem = result.problem;
    result.solved = problem.keyframes.size() >= 2 && !problem.points.empty();
    if (!result.solved) return result;
    result.finished = bundleAdjust(camera, problem.ba_keyframes, problem.ba_points, problem.ba_observations,
                                   options, abort);
    if (attempt > 0 || !result.finished) return result;
    std::unique_lock lock(map.mutex());
    const std::vector<map::Keyframe*> far = weakKeyframesMovedFar(problem, kMaxWeakKeyframeMoveM, true);
    const std::vector<map::Keyframe*> loose = looseGroupsMovedFar(problem, kMaxWeakKeyframeMoveM);
    if (far.empty() && loose.empty()) return result;
    for (map::Keyframe* k : far) k->pose_held = true;
    for (map::Keyframe* k : loose) k->pose_held = true;
    result.weak_keyframes_held += far.size();
    result.loose_groups_held += loose.size();
  }
  return result;
}

GlobalBaResult globalBundleAdjustment(map::Map& map, const PinholeCamera& camera,
                                      const BundleAdjustmentOptions& options, const std::atomic<bool>* abort) {
  const auto start = std::chrono::steady_clock::now();
  GlobalBaResult result;
  const GlobalBaSolve solve = solveGlobalBa(map, camera, options, abort);
  if (!solve.solved) return result;
  const MapBaProblem& problem = solve.problem;
  {
    std::unique_lock lock(map.mutex());
    applyMapBaResult(map, problem);
  }
  result.completed = solve.finished;
  result.weak_keyframes_held = solve.weak_keyframes_held;
  result.loose_groups_held = solve.loose_groups_held;
  result.keyframes = problem.keyframes.size();
  result.points = problem.points.size();
  result.observations = problem.ba_observations.size();
  for (const auto& o : problem.ba_observations) result.outliers += o.outlier ? 1 : 0;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace desslam::optim
