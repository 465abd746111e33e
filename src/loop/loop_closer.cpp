#include "loop/loop_closer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <shared_mutex>

#include <spdlog/spdlog.h>

#include "matching/matcher.hpp"
#include "optim/bundle_adjustment.hpp"
#include "optim/map_bundle_adjustment.hpp"
#include "optim/pose_graph.hpp"

namespace desslam::loop {

namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}
constexpr double kFuseRadiusPx = 4.0;

// Holds a MappingPause for a scope (no-op without one).
class PauseScope {
 public:
  explicit PauseScope(mapping::MappingPause* pause) : pause_(pause) {
    if (pause_ != nullptr) pause_->pause();
  }
  ~PauseScope() {
    if (pause_ != nullptr) pause_->resume();
  }
  PauseScope(const PauseScope&) = delete;
  PauseScope& operator=(const PauseScope&) = delete;

 private:
  mapping::MappingPause* pause_;
};
}  // namespace

// ---------------------------------------------------------------- LoopCloser

LoopCloser::LoopCloser(const LoopCloserOptions& options, const PinholeCamera& camera, map::Map& map,
                       place::KeyframeDatabase& database, mapping::MappingPause* pause, GlobalBaMode global_ba)
    : options_(options),
      camera_(camera),
      map_(map),
      pause_(pause),
      global_ba_mode_(options.loop.global_ba ? global_ba : GlobalBaMode::kOff),
      bf_(camera.bf()),
      detector_(options.loop, camera, map, database, options.atlas) {}

LoopCloser::~LoopCloser() { abortGlobalBa(); }

void LoopCloser::setListener(std::function<void(const LoopEvent&)> listener) {
  std::lock_guard lock(stats_mutex_);
  listener_ = std::move(listener);
}

LoopClosingStats LoopCloser::stats() const {
  std::lock_guard lock(stats_mutex_);
  return stats_;
}

void LoopCloser::notify(const LoopEvent& event) {
  std::function<void(const LoopEvent&)> listener;
  {
    std::lock_guard lock(stats_mutex_);
    listener = listener_;
  }
  if (listener) listener(event);
}

bool LoopCloser::process(map::Keyframe* kf) {
  if (!options_.loop.enabled) return false;
  std::optional<LoopMatch> match = detector_.detect(kf);
  std::optional<LoopMatch> suggested;
  {
    std::lock_guard lock(suggested_mutex_);
    if (auto it = suggested_.find(kf->id); it != suggested_.end()) {
      suggested = std::move(it->second);
      suggested_.erase(it);
    }
  }
  {
    std::lock_guard lock(stats_mutex_);
    stats_.detection = detector_.stats();
    if (match) ++stats_.loops_detected;
  }
  if (!match && suggested) {
    {
      std::shared_lock lock(map_.mutex());
      if (suggested->current->bad || suggested->loop->bad || suggested->current->map_id == suggested->loop->map_id)
        return false;  // culled, or merged meanwhile
    }
    return correctLoop(*suggested);
  }
  if (!match) return false;
  return correctLoop(*match);
}

int LoopCloser::mergeRemainingMaps(const std::atomic<bool>* abort) {
  if (!options_.loop.enabled || !options_.atlas.final_merge_search) return 0;
  int merges = 0;
  // Each merge leaves one map fewer: the search ends with one map or when it finds nothing.
  while (abort == nullptr || !abort->load()) {
    std::optional<LoopMatch> match = detector_.searchMergeAcrossMaps();
    {
      std::lock_guard lock(stats_mutex_);
      stats_.detection = detector_.stats();
      if (match) ++stats_.loops_detected;
    }
    if (!match || !correctLoop(*match)) break;
    ++merges;
    {
      std::lock_guard lock(stats_mutex_);
      ++stats_.merges_at_end;
    }
    if (!waitForGlobalBa(abort)) abortGlobalBa();
  }
  return merges;
}

void LoopCloser::suggestMerge(const LoopMatch& match) {
  LoopMatch suggested = match;
  suggested.merge = true;
  suggested.from_tracking = true;
  std::lock_guard lock(suggested_mutex_);
  suggested_[match.current->id] = std::move(suggested);
}

bool LoopCloser::correctLoop(const LoopMatch& match) {
  abortGlobalBa();  // its result would undo this correction
  uint64_t newest_in_graph = 0;
  if (!applyLoopCorrection(match, newest_in_graph)) return false;
  if (global_ba_mode_ == GlobalBaMode::kThread) {
    startGlobalBa(newest_in_graph);
  } else if (global_ba_mode_ == GlobalBaMode::kInline) {
    // On the caller's thread: an exception goes straight to it.
    global_ba_running_ = true;
    try {
      globalBa(newest_in_graph);
    } catch (...) {
      global_ba_running_ = false;
      throw;
    }
    global_ba_running_ = false;
  }
  return true;
}

// ---- the named steps loop correction and map merging share (each documents the lock it needs)

bool LoopCloser::mergeMaps(LoopMatch& match) {
  // Rigid move of the whole younger map into the older one's world; tracking waits (world gate).
  std::unique_lock world(map_.worldGate());
  std::unique_lock lock(map_.mutex());
  map::Keyframe* current = match.current;
  map::Keyframe* loop = match.loop;
  if (current->bad || loop->bad || current->map_id == loop->map_id) return false;
  MergedMaps merged;
  // match.T_w_c_corrected is K's pose in L's world: T_wL_wK = T_wL_K * T_K_wK.
  const SE3 T_wL_wK = match.T_w_c_corrected * current->T_c_w;
  if (loop->map_id < current->map_id) {
    merged = {current->map_id, loop->map_id, T_wL_wK};
  } else {
    merged = {loop->map_id, current->map_id, T_wL_wK.inverse()};
  }
  merged.current_keyframe = current->id;
  merged.loop_keyframe = loop->id;
  merged.timestamp = current->timestamp;
  merged.inliers = match.inliers;
  merged.found_by_tracking = match.from_tracking;
  map_.mergeMap(merged.from_map, merged.into_map, merged.T_into_from, current->timestamp);
  // One world now: what is left at K is the drift a loop corrects (none right after the move).
  match.T_w_c_corrected = current->T_w_c();
  {
    std::lock_guard s(stats_mutex_);
    stats_.merges.push_back(merged);
  }
  return true;
}

SE3 LoopCloser::correctNeighbourhood(const LoopMatch& match, const std::vector<map::Keyframe*>& connected,
                                     const std::map<uint64_t, SE3>& old_T_w_c) {
  const SE3 C = match.T_w_c_corrected * match.current->T_c_w;
  std::set<map::MapPoint*> moved;
  for (map::Keyframe* k : connected)
    for (map::MapPoint* p : k->points)
      if (p != nullptr && !p->bad && moved.insert(p).second) p->position = C * p->position;
  for (map::Keyframe* k : connected) k->T_c_w = (C * old_T_w_c.at(k->id)).inverse();
  return C;
}

size_t LoopCloser::replaceDuplicatedPoints(const LoopMatch& match, const std::vector<map::Keyframe*>& connected) {
  map::Keyframe* current = match.current;
  size_t fused = 0;
  // K's matched points become the loop's.
  for (size_t i = 0; i < match.matched_points.size(); ++i) {
    map::MapPoint* loop_point = match.matched_points[i];
    if (loop_point == nullptr || loop_point->bad) continue;
    map::MapPoint* own = current->points[i];
    if (own == loop_point) continue;
    if (own != nullptr && !own->bad) {
      map::replacePoint(map_, own, loop_point);
      ++fused;
    } else if (loop_point->observations.count(current->id) == 0) {
      map::addObservation(loop_point, current, static_cast<int>(i));
      map::updateDescriptor(loop_point);
      ++fused;
    }
  }
  // The loop group's points are fused into K's neighbourhood by projection.
  std::vector<map::MapPoint*> loop_points;
  {
    std::set<map::MapPoint*> unique;
    std::vector<map::Keyframe*> group{match.loop};
    for (map::Keyframe* nb : map::bestCovisibles(match.loop, options_.loop.group_size)) group.push_back(nb);
    for (map::Keyframe* g : group)
      for (map::MapPoint* p : g->points)
        if (p != nullptr && !p->bad && unique.insert(p).second) loop_points.push_back(p);
  }
  const MatcherOptions& matcher = options_.matching;
  for (map::Keyframe* k : connected)
    fused += static_cast<size_t>(matching::fuseIntoKeyframe(map_, k, loop_points, camera_, kFuseRadiusPx, matcher));
  return fused;
}

void LoopCloser::updateLoopConnections(const LoopMatch& match, const std::vector<map::Keyframe*>& connected,
                                       const std::map<uint64_t, std::set<uint64_t>>& links_before) {
  std::set<uint64_t> connected_ids;
  for (map::Keyframe* k : connected) connected_ids.insert(k->id);
  for (map::Keyframe* k : connected) {
    for (map::MapPoint* p : k->points)
      if (p != nullptr && !p->bad) map::updateNormalAndDepth(p);
    map::updateConnections(k);
  }
  // New links from K's neighbourhood to keyframes outside it are the loop's edges.
  bool linked_to_loop = false;
  for (map::Keyframe* k : connected)
    for (auto& [id, entry] : k->connection_weights) {
      auto before = links_before.find(k->id);
      if (connected_ids.count(id) != 0 || (before != links_before.end() && before->second.count(id) != 0)) continue;
      loop_edges_.emplace_back(k, entry.first);
      linked_to_loop = linked_to_loop || entry.first == match.loop;
    }
  if (!linked_to_loop) loop_edges_.emplace_back(match.current, match.loop);
}

LoopCloser::EssentialGraph LoopCloser::buildEssentialGraph(const map::Keyframe* loop,
                                                           const std::map<uint64_t, SE3>& old_T_w_c) const {
  EssentialGraph graph;
  std::map<uint64_t, int> index;
  // The loop's map only: other maps of the atlas have worlds of their own.
  for (map::Keyframe* k : map_.keyframes()) {
    if (k->map_id != loop->map_id) continue;
    index[k->id] = static_cast<int>(graph.keyframes.size());
    graph.keyframes.push_back(k);
    graph.snapshot_T_c_w[k->id] = k->T_c_w;
    graph.nodes.push_back({k->T_w_c(), k == loop});
    graph.newest = std::max(graph.newest, k->id);
  }
  auto oldRelative = [&](map::Keyframe* a, map::Keyframe* b) {
    auto ia = old_T_w_c.find(a->id), ib = old_T_w_c.find(b->id);
    // Keyframes created while this ran have no "old" pose: their present one is it.
    const SE3 Ta = ia != old_T_w_c.end() ? ia->second : a->T_w_c();
    const SE3 Tb = ib != old_T_w_c.end() ? ib->second : b->T_w_c();
    return Ta.inverse() * Tb;
  };
  std::set<std::pair<int, int>> added;
  auto addEdge = [&](map::Keyframe* a, map::Keyframe* b, const SE3& T_a_b) {
    auto ia = index.find(a->id), ib = index.find(b->id);
    if (ia == index.end() || ib == index.end() || ia->second == ib->second) return;
    const auto key = std::minmax(ia->second, ib->second);
    if (!added.insert(key).second) return;
    graph.edges.push_back({ia->second, ib->second, T_a_b, 1.0});
  };
  // Loop edges first (measured on the corrected poses) so they win over odometry duplicates.
  for (auto& [a, b] : loop_edges_)
    if (!a->bad && !b->bad) addEdge(a, b, a->T_w_c().inverse() * b->T_w_c());
  for (map::Keyframe* k : graph.keyframes) {
    if (k->parent != nullptr && !k->parent->bad) addEdge(k->parent, k, oldRelative(k->parent, k));
    for (map::Keyframe* nb : map::covisiblesWithWeight(k, options_.loop.strong_covisibility_weight))
      if (nb->id < k->id) addEdge(nb, k, oldRelative(nb, k));
  }
  return graph;
}

SE3 LoopCloser::applyPoseGraph(const EssentialGraph& graph, bool usable, const map::Keyframe* current,
                               int map_id, const SE3& C) {
  std::map<uint64_t, SE3> correction;  // keyframe id -> T_wnew_wsnapshot
  for (size_t i = 0; i < graph.keyframes.size(); ++i) {
    map::Keyframe* k = graph.keyframes[i];
    const SE3 D = usable ? graph.nodes[i].T_w_c * graph.snapshot_T_c_w.at(k->id) : SE3();
    correction[k->id] = D;
    if (!k->bad) k->T_c_w = (D * k->T_w_c()).inverse();
  }
  const SE3 current_correction = correction.count(current->id) ? correction[current->id] : SE3();
  // Keyframes tracking made while this ran were placed in the old world.
  for (map::Keyframe* k : map_.keyframes()) {
    if (k->map_id != map_id || correction.count(k->id) != 0) continue;
    const SE3 D = current_correction * C;
    correction[k->id] = D;
    k->T_c_w = (D * k->T_w_c()).inverse();
  }
  // Points follow their reference keyframe (or any observer the graph moved).
  for (map::MapPoint* p : map_.points()) {
    if (p->map_id != map_id) continue;
    const map::Keyframe* ref = p->reference;
    auto it = ref != nullptr ? correction.find(ref->id) : correction.end();
    if (it == correction.end()) {
      for (auto& [kid, obs] : p->observations) {
        it = correction.find(kid);
        if (it != correction.end()) break;
      }
    }
    if (it == correction.end()) continue;
    p->position = it->second * p->position;
    map::updateNormalAndDepth(p);
  }
  return current_correction;
}

bool LoopCloser::applyLoopCorrection(const LoopMatch& detected, uint64_t& newest_in_graph) {
  const auto start = Clock::now();
  std::lock_guard correction(correction_mutex_);
  PauseScope paused(pause_);

  LoopMatch match = detected;
  const auto skipped = [&] {
    std::lock_guard s(stats_mutex_);
    ++stats_.loops_skipped;
    return false;
  };
  // Step 0 (a merge): the two maps become one, by the rigid transform recognition found.
  if (match.merge && !mergeMaps(match)) return skipped();

  map::Keyframe* current = match.current;
  map::Keyframe* loop = match.loop;
  EssentialGraph graph;
  SE3 C;  // T_wnew_wold at K (step 1)
  size_t fused = 0;
  int map_id = 0;
  {
    std::unique_lock lock(map_.mutex());
    if (current->bad || loop->bad) return skipped();
    map_id = loop->map_id;
    map::updateConnections(current);
    std::vector<map::Keyframe*> connected{current};
    for (map::Keyframe* nb : map::bestCovisibles(current, 0)) connected.push_back(nb);
    // Poses before any change: the essential graph's odometry edges are measured on them.
    std::map<uint64_t, SE3> old_T_w_c;
    for (map::Keyframe* k : map_.keyframes()) old_T_w_c[k->id] = k->T_w_c();
    std::map<uint64_t, std::set<uint64_t>> links_before;
    for (map::Keyframe* k : connected)
      for (auto& [id, entry] : k->connection_weights) links_before[k->id].insert(id);

    C = correctNeighbourhood(match, connected, old_T_w_c);      // 1. K's neighbourhood into L's world
    fused = replaceDuplicatedPoints(match, connected);           // 2. one point per place
    updateLoopConnections(match, connected, links_before);       // 3. covisibility, loop edges
    graph = buildEssentialGraph(loop, old_T_w_c);                // 4. pose graph input
  }
  newest_in_graph = graph.newest;

  // 5. Pose graph on copies; tracking goes on meanwhile.
  const auto graph_start = Clock::now();
  optim::PoseGraphOptions graph_options;
  graph_options.iterations = options_.loop.pose_graph_iterations;
  const optim::PoseGraphSummary summary = optim::optimizePoseGraph(graph.nodes, graph.edges, graph_options);
  const double graph_ms = msSince(graph_start);

  // 6. Write back; points follow their reference keyframe.
  SE3 current_correction;
  {
    std::unique_lock lock(map_.mutex());
    current_correction = applyPoseGraph(graph, summary.usable, current, map_id, C);
  }
  detector_.loopClosed(current->id);
  std::optional<MergedMaps> merged;  // this correction's merge, for the log line
  {
    std::lock_guard s(stats_mutex_);
    ++stats_.loops_closed;
    stats_.closed.push_back({current->id, loop->id, current->timestamp, loop->timestamp, match.inliers,
                             C.translation().norm(), C.rotationAngle() * 180.0 / M_PI, detected.merge});
    stats_.points_fused += fused;
    stats_.pose_graph_ms.push_back(graph_ms);
    stats_.correction_ms.push_back(msSince(start));
    stats_.detection = detector_.stats();
    if (detected.merge && !stats_.merges.empty()) merged = stats_.merges.back();
  }
  // One line per correction (outside the stats lock): a run has a handful, and each moves the
  // trajectory users evaluate.
  if (merged) {
    spdlog::info("loop: map {} merged into map {} (keyframe {}, t {:.3f}, seen in keyframe {}, t {:.3f}; {} inliers{}), "
                 "{} points fused", merged->from_map, merged->into_map, current->id, current->timestamp, loop->id,
                 loop->timestamp, match.inliers, detected.from_tracking ? ", found by tracking" : "", fused);
  } else {
    spdlog::info("loop: closed at keyframe {} (t {:.3f}) with keyframe {} (t {:.3f}), map {}: {} inliers, correction "
                 "{:.3f} m {:.2f} deg, {} points fused", current->id, current->timestamp, loop->id, loop->timestamp,
                 map_id, match.inliers, C.translation().norm(), C.rotationAngle() * 180.0 / M_PI, fused);
  }
  notify({detected.merge ? LoopEvent::Kind::kMapsMerged : LoopEvent::Kind::kLoopCorrected, current->id, loop->id,
          current_correction * C});
  return true;
}

void LoopCloser::startGlobalBa(uint64_t newest_keyframe) {
  abortGlobalBa();
  global_ba_abort_ = false;
  global_ba_running_ = true;
  global_ba_thread_ = std::thread([this, newest_keyframe] { runGlobalBa(newest_keyframe); });
}

void LoopCloser::abortGlobalBa() {
  global_ba_abort_ = true;
  if (global_ba_thread_.joinable()) global_ba_thread_.join();
  global_ba_abort_ = false;
}

bool LoopCloser::waitForGlobalBa(const std::atomic<bool>* abort) {
  std::unique_lock lock(ba_wait_mutex_);
  if (abort == nullptr) {
    ba_done_cv_.wait(lock, [&] { return !global_ba_running_.load(); });
    return true;
  }
  // The abort flag may be set by a signal handler, which cannot notify: poll it.
  while (!ba_done_cv_.wait_for(lock, std::chrono::milliseconds(20), [&] { return !global_ba_running_.load(); }))
    if (abort->load()) return false;
  return true;
}

std::exception_ptr LoopCloser::failure() const {
  std::lock_guard lock(ba_wait_mutex_);
  return global_ba_failure_;
}

void LoopCloser::runGlobalBa(uint64_t newest_keyframe) {
  std::exception_ptr failure;
  try {
    globalBa(newest_keyframe);
  } catch (...) {
    failure = std::current_exception();
  }
  {
    std::lock_guard lock(ba_wait_mutex_);
    if (failure && !global_ba_failure_) global_ba_failure_ = failure;
    global_ba_running_ = false;
  }
  ba_done_cv_.notify_all();
}

void LoopCloser::globalBa(uint64_t newest_keyframe) {
  const auto start = Clock::now();
  {
    std::lock_guard s(stats_mutex_);
    ++stats_.global_ba_runs;
  }
  optim::BundleAdjustmentOptions ba;
  ba.bf = bf_;
  ba.iterations = options_.loop.global_ba_iterations;
  const optim::GlobalBaSolve solve = optim::solveGlobalBa(map_, camera_, ba, &global_ba_abort_);
  const std::vector<map::Keyframe*>& keyframes = solve.problem.keyframes;
  const std::vector<map::MapPoint*>& points = solve.problem.points;
  const std::vector<optim::BaKeyframe>& ba_keyframes = solve.problem.ba_keyframes;
  const std::vector<optim::BaPoint>& ba_points = solve.problem.ba_points;
  {
    std::lock_guard s(stats_mutex_);
    stats_.weak_keyframes_held += solve.weak_keyframes_held;
    stats_.loose_groups_held += solve.loose_groups_held;
  }
  const bool finished = solve.solved && solve.finished;
  if (finished && !global_ba_abort_) {
    std::lock_guard correction(correction_mutex_);
    PauseScope paused(pause_);
    SE3 newest_correction;
    {
      std::unique_lock lock(map_.mutex());
      std::map<uint64_t, SE3> correction;  // T_wnew_wold per keyframe
      for (size_t i = 0; i < keyframes.size(); ++i) {
        map::Keyframe* k = keyframes[i];
        if (k->bad) continue;
        correction[k->id] = ba_keyframes[i].T_c_w.inverse() * k->T_c_w;
        k->T_c_w = ba_keyframes[i].T_c_w;
      }
      // Keyframes added since the snapshot follow their spanning-tree parent (ids ascend, so a
      // parent is handled before its children).
      for (map::Keyframe* k : map_.keyframes()) {
        if (correction.count(k->id) != 0) continue;
        SE3 D;
        if (k->parent != nullptr && correction.count(k->parent->id) != 0) D = correction[k->parent->id];
        correction[k->id] = D;
        k->T_c_w = (D * k->T_w_c()).inverse();
      }
      std::set<const map::MapPoint*> optimised;
      for (size_t i = 0; i < points.size(); ++i) {
        if (points[i]->bad) continue;
        points[i]->position = ba_points[i].p_w;
        optimised.insert(points[i]);
      }
      for (map::MapPoint* p : map_.points()) {
        if (optimised.count(p) == 0 && p->reference != nullptr) {
          auto it = correction.find(p->reference->id);
          if (it != correction.end()) p->position = it->second * p->position;
        }
        map::updateNormalAndDepth(p);
      }
      auto it = correction.find(newest_keyframe);
      if (it != correction.end()) newest_correction = it->second;
    }
    {
      std::lock_guard s(stats_mutex_);
      ++stats_.global_ba_applied;
      stats_.global_ba_ms.push_back(msSince(start));
    }
    notify({LoopEvent::Kind::kGlobalBaApplied, newest_keyframe, 0, newest_correction});
  } else {
    std::lock_guard s(stats_mutex_);
    ++stats_.global_ba_aborted;
  }
}

// ---------------------------------------------------------------- LoopClosingThread

LoopClosingThread::LoopClosingThread(LoopCloser& closer, size_t capacity)
    : closer_(closer),
      worker_("loop closing", capacity, QueueFullPolicy::kDropOldest, [this](map::Keyframe*& kf) { closer_.process(kf); }) {}

LoopClosingThread::~LoopClosingThread() { stop(); }

void LoopClosingThread::push(map::Keyframe* kf) { worker_.push(kf); }

void LoopClosingThread::waitUntilIdle() {
  worker_.waitUntilIdle();
  closer_.waitForGlobalBa();
}

void LoopClosingThread::stop(const std::atomic<bool>* abort) {
  worker_.stop();
  if (!closer_.waitForGlobalBa(abort)) closer_.abortGlobalBa();  // the worker has stopped: safe here
}

}  // namespace desslam::loop
