#include "mapping/local_mapper.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <shared_mutex>

#include <spdlog/spdlog.h>

#include <Eigen/SVD>

#include <set>

#include "optim/map_bundle_adjustment.hpp"
#include "optim/bundle_adjustment.hpp"

namespace desslam::mapping {

namespace {
constexpr double kChi2Mono = 5.991;
constexpr double kChi2Rgbd = 7.815;
constexpr double kChi2Epipolar = 3.84;
constexpr double kMinFoundRatio = 0.25;  // recent points matched in under a quarter of the frames that see them go
constexpr int kFuseNeighbours = 10;
constexpr int kFuseSecondNeighbours = 5;
constexpr double kFuseRadius = 3.0;
constexpr size_t kMaxLocalKeyframes = 25;
constexpr size_t kMaxFixedKeyframes = 30;

// Observations weighted as in the ORB-SLAM2 paper's stereo/RGB-D case: one with depth counts
// twice, since it constrains the point alone.
int observationWeight(const map::MapPoint* p) {
  int n = 0;
  for (const auto& [id, obs] : p->observations) n += obs.first->features->hasDepth(obs.second) ? 2 : 1;
  return n;
}

// Linear triangulation (DLT) from two views, normalised image coordinates.
Vec3 triangulate(const Vec3& xn1, const Vec3& xn2, const SE3& T1, const SE3& T2) {
  Eigen::Matrix<double, 3, 4> P1, P2;
  P1 << T1.rotation(), T1.translation();
  P2 << T2.rotation(), T2.translation();
  Eigen::Matrix4d A;
  A.row(0) = xn1.x() * P1.row(2) - P1.row(0);
  A.row(1) = xn1.y() * P1.row(2) - P1.row(1);
  A.row(2) = xn2.x() * P2.row(2) - P2.row(0);
  A.row(3) = xn2.y() * P2.row(2) - P2.row(1);
  Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  return X.head<3>() / X(3);
}
}  // namespace

LocalMapper::LocalMapper(const LocalMapperOptions& options, const PinholeCamera& camera, map::Map& map,
                         place::KeyframeDatabase* database)
    : options_(options), camera_(camera), map_(map), database_(database), bf_(camera.bf()) {
  matcher_options_ = options.matching;
}

void LocalMapper::process(map::Keyframe* kf, const std::atomic<bool>* abort_ba) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto step = start;
  auto lap = [&step](std::vector<double>& out) {
    const auto now = Clock::now();
    out.push_back(std::chrono::duration<double, std::milli>(now - step).count());
    step = now;
  };
  insertKeyframe(kf);
  if (database_ != nullptr) database_->add(kf);  // encodes outside the Map lock
  lap(stats_.insert_ms);
  cullRecentPoints(kf);
  lap(stats_.cull_points_ms);
  triangulateNewPoints(kf);
  lap(stats_.triangulate_ms);
  fuseWithNeighbours(kf);
  lap(stats_.fuse_ms);
  if (options_.mapping.local_ba) localBundleAdjustment(kf, abort_ba);
  lap(stats_.ba_ms);
  cullRedundantKeyframes(kf);
  lap(stats_.cull_keyframes_ms);
  stats_.total_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  ++stats_.keyframes_processed;
}

void LocalMapper::insertKeyframe(map::Keyframe* kf) {
  std::unique_lock lock(map_.mutex());
  for (map::MapPoint* p : kf->points) {
    if (p == nullptr || p->bad) continue;
    if (p->created_at_keyframe == kf->id) {
      recent_points_.push_back(p);
    } else {
      map::updateNormalAndDepth(p);
      map::updateDescriptor(p);
    }
  }
  map::updateConnections(kf);
}

void LocalMapper::cullRecentPoints(map::Keyframe* kf) {
  std::unique_lock lock(map_.mutex());
  std::vector<map::MapPoint*> kept;
  for (map::MapPoint* p : recent_points_) {
    if (p->bad) continue;
    const uint64_t age = kf->id - p->created_at_keyframe;
    if (p->foundRatio() < kMinFoundRatio || (age >= 2 && observationWeight(p) <= 3)) {
      map_.setPointBad(p);
      ++stats_.points_culled;
    } else if (age < 3) {
      kept.push_back(p);
    }
  }
  recent_points_.swap(kept);
}

void LocalMapper::triangulateNewPoints(map::Keyframe* kf) {
  struct Candidate {
    map::Keyframe* neighbour;
    int feature_kf, feature_neighbour;
    Vec3 position;
  };
  std::vector<Candidate> accepted;
  const map::FeatureSet& f1 = *kf->features;
  const auto& pyramid = *f1.pyramid;
  const double ratio_factor = 1.5 * pyramid.scale[1];
  const Mat3 K_inv = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(camera_.K().ptr<double>()).inverse();
  {
    std::shared_lock lock(map_.mutex());
    const SE3 T1 = kf->T_c_w;
    const Vec3 c1 = kf->center();
    std::vector<int> free1;
    for (size_t i = 0; i < f1.size(); ++i)
      if (kf->points[i] == nullptr && kf->usable(i)) free1.push_back(static_cast<int>(i));

    for (map::Keyframe* nb : map::bestCovisibles(kf, options_.mapping.covisible_for_triangulation)) {
      const map::FeatureSet& f2 = *nb->features;
      const SE3 T2 = nb->T_c_w;
      const Vec3 c2 = nb->center();
      // Too short a baseline triangulates nothing depth did not already give.
      if ((c2 - c1).norm() < camera_.depthBaseline()) continue;
      std::vector<int> free2;
      for (size_t i = 0; i < f2.size(); ++i)
        if (nb->points[i] == nullptr && nb->usable(i)) free2.push_back(static_cast<int>(i));

      // Fundamental matrix F21 (x2^T F21 x1 = 0) from the relative pose.
      const SE3 T21 = T2 * T1.inverse();
      const Mat3 F21 = K_inv.transpose() * skew(T21.translation()) * T21.rotation() * K_inv;
      auto epipolar = [&](int i1, int i2) {
        const Vec3 x1(f1.uv[i1].x(), f1.uv[i1].y(), 1.0);
        const Vec3 line = F21 * x1;
        const double num = line.dot(Vec3(f2.uv[i2].x(), f2.uv[i2].y(), 1.0));
        const double den = line.head<2>().squaredNorm();
        return den > 0 && num * num / den < kChi2Epipolar * pyramid.sigma2[f2.level(i2)];
      };
      const auto pairs = matching::matchDescriptors(f1, free1, f2, free2, matcher_options_.strict_distance, 0.7,
                                                    false, epipolar);
      for (auto [i1, i2] : pairs) {
        const Vec3 xn1 = K_inv * Vec3(f1.uv[i1].x(), f1.uv[i1].y(), 1.0);
        const Vec3 xn2 = K_inv * Vec3(f2.uv[i2].x(), f2.uv[i2].y(), 1.0);
        const Vec3 ray1 = T1.rotation().transpose() * xn1;
        const Vec3 ray2 = T2.rotation().transpose() * xn2;
        const double cos_rays = ray1.dot(ray2) / (ray1.norm() * ray2.norm());
        const double b = camera_.depthBaseline();
        const double cos_depth1 = f1.hasDepth(i1) ? std::cos(2 * std::atan2(b / 2, f1.depth[i1])) : 2.0;
        const double cos_depth2 = f2.hasDepth(i2) ? std::cos(2 * std::atan2(b / 2, f2.depth[i2])) : 2.0;
        const double cos_depth = std::min(cos_depth1, cos_depth2);
        Vec3 X;
        if (cos_rays < cos_depth && cos_rays > 0 && (f1.hasDepth(i1) || f2.hasDepth(i2) || cos_rays < 0.9998)) {
          X = triangulate(xn1, xn2, T1, T2);
        } else if (f1.hasDepth(i1) && cos_depth1 <= cos_depth2) {
          X = T1.inverse() * camera_.backProject(f1.uv[i1], f1.depth[i1]);
        } else if (f2.hasDepth(i2)) {
          X = T2.inverse() * camera_.backProject(f2.uv[i2], f2.depth[i2]);
        } else {
          continue;  // no parallax and no depth
        }
        if (!X.allFinite()) continue;
        // In front of both cameras, reprojecting within the keypoints' uncertainty.
        bool ok = true;
        for (int view = 0; view < 2 && ok; ++view) {
          const SE3& T = view == 0 ? T1 : T2;
          const map::FeatureSet& f = view == 0 ? f1 : f2;
          const int i = view == 0 ? i1 : i2;
          const Vec3 p_c = T * X;
          if (p_c.z() <= 0) {
            ok = false;
            break;
          }
          double chi2 = (camera_.project(p_c) - f.uv[i]).squaredNorm();
          double threshold = kChi2Mono;
          if (f.hasDepth(i)) {
            const double er = bf_ / p_c.z() - bf_ / f.depth[i];
            chi2 += er * er;
            threshold = kChi2Rgbd;
          }
          ok = chi2 * pyramid.inv_sigma2[f.level(i)] <= threshold;
        }
        if (!ok) continue;
        // Scale consistency: distance ratio must agree with the pyramid levels' ratio.
        const double d1 = (X - c1).norm(), d2 = (X - c2).norm();
        if (d1 <= 0 || d2 <= 0) continue;
        const double ratio_distance = d2 / d1;
        const double ratio_octave = pyramid.scale[f1.level(i1)] / pyramid.scale[f2.level(i2)];
        if (ratio_distance * ratio_factor < ratio_octave || ratio_distance > ratio_octave * ratio_factor) continue;
        accepted.push_back({nb, i1, i2, X});
        // A feature of kf is used once.
        free1.erase(std::remove(free1.begin(), free1.end(), i1), free1.end());
      }
    }
  }

  std::unique_lock lock(map_.mutex());
  for (const Candidate& c : accepted) {
    if (kf->bad || c.neighbour->bad) continue;
    if (kf->points[c.feature_kf] != nullptr || c.neighbour->points[c.feature_neighbour] != nullptr) continue;
    map::MapPoint* p = map_.createPoint(c.position, kf);
    map::addObservation(p, kf, c.feature_kf);
    map::addObservation(p, c.neighbour, c.feature_neighbour);
    map::updateDescriptor(p);
    map::updateNormalAndDepth(p);
    recent_points_.push_back(p);
    ++stats_.points_triangulated;
  }
}

void LocalMapper::fuseWithNeighbours(map::Keyframe* kf) {
  std::unique_lock lock(map_.mutex());
  std::map<uint64_t, map::Keyframe*> targets;
  for (map::Keyframe* nb : map::bestCovisibles(kf, kFuseNeighbours)) {
    targets.emplace(nb->id, nb);
    for (map::Keyframe* nb2 : map::bestCovisibles(nb, kFuseSecondNeighbours))
      if (nb2 != kf) targets.emplace(nb2->id, nb2);
  }
  // kf's points into its neighbours...
  for (auto& [id, target] : targets) {
    std::vector<map::MapPoint*> points;
    for (map::MapPoint* p : kf->points)
      if (p != nullptr && !p->bad) points.push_back(p);
    matching::fuseIntoKeyframe(map_, target, points, camera_, kFuseRadius, matcher_options_);
  }
  // ...and the neighbours' points into kf.
  std::vector<map::MapPoint*> candidates;
  std::map<uint64_t, map::MapPoint*> unique;
  for (auto& [id, target] : targets)
    for (map::MapPoint* p : target->points)
      if (p != nullptr && !p->bad) unique.emplace(p->id, p);
  for (auto& [id, p] : unique) candidates.push_back(p);
  matching::fuseIntoKeyframe(map_, kf, candidates, camera_, kFuseRadius, matcher_options_);

  for (map::MapPoint* p : kf->points) {
    if (p == nullptr || p->bad) continue;
    map::updateDescriptor(p);
    map::updateNormalAndDepth(p);
  }
  map::updateConnections(kf);
}

std::optional<optim::MapBaProblem> LocalMapper::localBaProblem(map::Keyframe* kf) const {
  std::shared_lock lock(map_.mutex());
  std::vector<map::Keyframe*> keyframes{kf};  // local first, then fixed
  for (map::Keyframe* nb : map::bestCovisibles(kf, 0)) {
    if (keyframes.size() >= kMaxLocalKeyframes) break;
    keyframes.push_back(nb);
  }
  const size_t local_count = keyframes.size();
  std::set<uint64_t> local_ids;
  for (map::Keyframe* k : keyframes) local_ids.insert(k->id);
  // Keyframes outside the local window that see local points hold the gauge, fixed.
  std::map<uint64_t, std::pair<map::Keyframe*, int>> fixed_votes;
  std::set<uint64_t> seen_points;
  for (size_t i = 0; i < local_count; ++i)
    for (map::MapPoint* p : keyframes[i]->points) {
      if (p == nullptr || p->bad || !seen_points.insert(p->id).second) continue;
      for (auto& [kid, obs] : p->observations)
        if (local_ids.count(kid) == 0 && !obs.first->bad) {
          auto& v = fixed_votes[kid];
          v.first = obs.first;
          ++v.second;
        }
    }
  std::vector<std::pair<int, map::Keyframe*>> fixed;
  for (auto& [kid, v] : fixed_votes) fixed.emplace_back(v.second, v.first);
  std::sort(fixed.begin(), fixed.end(),
            [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second->id < b.second->id; });
  for (auto& [votes, fkf] : fixed) {
    if (keyframes.size() - local_count >= kMaxFixedKeyframes) break;
    keyframes.push_back(fkf);
  }
  std::vector<bool> is_fixed(keyframes.size());
  for (size_t i = 0; i < keyframes.size(); ++i)
    is_fixed[i] = i >= local_count || keyframes[i]->map_origin || keyframes[i]->pose_held;
  // With nothing fixed (early map) the oldest keyframe holds the gauge.
  if (std::none_of(is_fixed.begin(), is_fixed.end(), [](bool f) { return f; })) {
    auto oldest = std::min_element(keyframes.begin(), keyframes.end(),
                                   [](const map::Keyframe* a, const map::Keyframe* b) { return a->id < b->id; });
    is_fixed[oldest - keyframes.begin()] = true;
  }
  if (keyframes.size() < 2) return std::nullopt;
  return optim::buildMapBaProblem(keyframes, is_fixed);
}

void LocalMapper::localBundleAdjustment(map::Keyframe* kf, const std::atomic<bool>* abort_ba) {
  // A keyframe made at a weak pose shares few points with the map, and the solve can carry it far
  // with its own new points: one on an fr1_xyz composite (5-frame-old masks, 20 inliers) moved
  // 21 cm in its first local BA and ended 46 cm off, with the frames tracked from it. Such a
  // keyframe the solve would move more than kMaxWeakKeyframeMoveM is held where tracking put it
  // (Keyframe::pose_held) and the window solved again; held keyframes stay fixed, so at most once.
  // Any other keyframe the solve would move more than kMaxKeyframeMoveM is held too, and then the
  // window's keyframes all stay where they are for the second solve (only the points move): the
  // solve had slid a part of the window, and holding one keyframe of it while the others slid on
  // bent the map (fr1_xyz composite, 5-frame-old masks: two keyframes moved 9.6 and 11.8 cm
  // together from right tracked poses; holding only the one over the bar, ATE 0.016 -> 0.064 m).
  bool fix_window = false;
  for (int attempt = 0; attempt < 2; ++attempt) {
    std::optional<optim::MapBaProblem> problem = localBaProblem(kf);
    if (!problem) return;
    if (fix_window)
      for (optim::BaKeyframe& window_keyframe : problem->ba_keyframes) window_keyframe.fixed = true;
    optim::BundleAdjustmentOptions ba;
    ba.bf = bf_;
    ba.iterations = options_.mapping.local_ba_iterations;
    const bool finished = optim::bundleAdjust(camera_, problem->ba_keyframes, problem->ba_points,
                                              problem->ba_observations, ba, abort_ba);
    ++stats_.ba_runs;
    if (!finished) ++stats_.ba_aborted;

    std::unique_lock lock(map_.mutex());
    if (attempt == 0) {
      const HeldKeyframes held = holdKeyframesMovedFar(*problem);
      if (held.weak + held.other > 0) {
        fix_window = held.other > 0;
        continue;
      }
    }
    optim::applyMapBaResult(map_, *problem);
    return;
  }
}

LocalMapper::HeldKeyframes LocalMapper::holdKeyframesMovedFar(const optim::MapBaProblem& problem) {
  HeldKeyframes held;
  // On 35 fr1 composite runs the weak-pose bar acted in 7.
  for (map::Keyframe* k :
       optim::weakKeyframesMovedFar(problem, optim::kMaxWeakKeyframeMoveM, /*relative_to_parent=*/false)) {
    spdlog::debug("mapping: keyframe {} (made at a weak pose) would move over {:.2f} m in local BA: held", k->id,
                  optim::kMaxWeakKeyframeMoveM);
    k->pose_held = true;
    ++held.weak;
  }
  for (map::Keyframe* k : optim::keyframesMovedFar(problem, optim::kMaxKeyframeMoveM)) {
    spdlog::debug("mapping: keyframe {} would move over {:.2f} m in local BA: held, the window's keyframes kept",
                  k->id, optim::kMaxKeyframeMoveM);
    k->pose_held = true;
    ++held.other;
  }
  stats_.weak_keyframes_held += held.weak;
  stats_.keyframes_held_moved_far += held.other;
  return held;
}

void LocalMapper::cullRedundantKeyframes(map::Keyframe* kf) {
  std::unique_lock lock(map_.mutex());
  for (map::Keyframe* candidate : map::bestCovisibles(kf, 0)) {
    if (candidate->map_origin || candidate->pose_held || candidate->bad || candidate->not_erase) continue;
    const map::FeatureSet& f = *candidate->features;
    int considered = 0, redundant = 0;
    for (size_t i = 0; i < candidate->points.size(); ++i) {
      map::MapPoint* p = candidate->points[i];
      if (p == nullptr || p->bad) continue;
      // Only close depth-backed points count (far ones are weakly constrained anyway).
      if (!f.hasDepth(i) || f.depth[i] > options_.tracking.close_depth) continue;
      ++considered;
      if (p->observations.size() <= 3) continue;
      const int level = f.level(i);
      int seen_by = 0;
      for (auto& [oid, obs] : p->observations) {
        if (obs.first == candidate) continue;
        if (obs.first->features->level(obs.second) <= level + 1) ++seen_by;
        if (seen_by >= 3) break;
      }
      if (seen_by >= 3) ++redundant;
    }
    if (considered > 0 && redundant > options_.mapping.redundant_keyframe_ratio * considered) {
      map_.setKeyframeBad(candidate);
      if (database_ != nullptr) database_->erase(candidate->id);
      ++stats_.keyframes_culled;
    }
  }
}

LocalMappingThread::LocalMappingThread(LocalMapper& mapper, MappingPause* pause,
                                       std::function<void(map::Keyframe*)> on_processed,
                                       std::function<void(map::Keyframe*)> before_processing)
    : mapper_(mapper),
      pause_(pause),
      on_processed_(std::move(on_processed)),
      before_processing_(std::move(before_processing)),
      worker_("local mapping", 8, QueueFullPolicy::kBlock, [this](map::Keyframe*& kf) { process(kf); }) {
  if (pause_ != nullptr) pause_->setAbortFlag(&abort_ba_);
}

LocalMappingThread::~LocalMappingThread() { stop(); }

void LocalMappingThread::push(map::Keyframe* kf) {
  abort_ba_ = true;  // a BA in progress yields to the newer keyframe
  worker_.push(kf);  // refused (and not counted) once stopped or failed
}

void LocalMappingThread::stop() { worker_.stop(); }

void LocalMappingThread::process(map::Keyframe* kf) {
  if (before_processing_) before_processing_(kf);
  {
    // Left on the way out too: a failed keyframe must not keep loop closing waiting for the pause.
    struct Bracket {
      MappingPause* pause;
      explicit Bracket(MappingPause* p) : pause(p) {
        if (pause != nullptr) pause->enter();
      }
      ~Bracket() {
        if (pause != nullptr) pause->leave();
      }
    } bracket(pause_);
    abort_ba_ = worker_.queued() > 0;
    mapper_.process(kf, &abort_ba_);
  }
  if (on_processed_) on_processed_(kf);
}

}  // namespace desslam::mapping
