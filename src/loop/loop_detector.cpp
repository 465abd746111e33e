#include "loop/loop_detector.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <shared_mutex>

#include <spdlog/spdlog.h>

#include "feature/descriptor.hpp"
#include "loop/rigid_estimation.hpp"
#include "matching/matcher.hpp"

namespace desslam::loop {

namespace {

// Camera-frame 3-D point of a keyframe feature: its depth reading, else its map point.
bool cameraPoint(const map::Keyframe* kf, int i, const PinholeCamera& camera, Vec3& p_c) {
  const map::FeatureSet& f = *kf->features;
  if (f.hasDepth(i)) {
    p_c = camera.backProject(f.uv[i], f.depth[i]);
    return true;
  }
  const map::MapPoint* p = kf->points[i];
  if (p == nullptr || p->bad) return false;
  p_c = kf->T_c_w * p->position;
  return p_c.z() > 0;
}

// The feature of `kf` whose descriptor is closest to `p`'s where the pose T_c_w (camera centre
// `center`) projects it, searched at the predicted pyramid level within radius_px (level 0) scaled
// to it, among the features `available(i)` accepts; -1 when none is within max_distance. p_c: the
// point in the camera frame.
template <class Available>
int projectedMatch(const map::Keyframe* kf, const SE3& T_c_w, const Vec3& center, const map::MapPoint* p,
                   const PinholeCamera& camera, double radius_px, int max_distance, Available available, Vec3& p_c) {
  if (p->descriptor.empty()) return -1;
  p_c = T_c_w * p->position;
  if (p_c.z() <= 0) return -1;
  const Vec2 uv = camera.project(p_c);
  if (!camera.inImage(uv)) return -1;
  const map::FeatureSet& f = *kf->features;
  const auto& pyramid = *f.pyramid;
  const double distance = (p->position - center).norm();
  if (p->max_distance > 0 && (distance < 0.8 * p->min_distance || distance > 1.2 * p->max_distance)) return -1;
  const int level = p->max_distance > 0 ? map::predictLevel(p, distance, pyramid) : 0;
  const double radius = radius_px * pyramid.scale[level];
  int best = feature::kMaxDescriptorDistance + 1, best_i = -1;
  for (int i : f.inArea(uv.x(), uv.y(), radius, std::max(0, level - 1), level + 1)) {
    if (!kf->usable(i) || !available(i)) continue;
    const int d = feature::descriptorDistance(p->descriptor.ptr<uint8_t>(), f.descriptor(i));
    if (d < best) {
      best = d;
      best_i = i;
    }
  }
  return best <= max_distance ? best_i : -1;
}

constexpr size_t kMaxMergeEvidence = 256;  // merge evidence kept (oldest dropped)
// searchMergeAcrossMaps(): per keyframe, the other maps' keyframes its bag of words ranks best.
constexpr int kFinalMergeCandidates = 10;

RigidRansacOptions ransacOptions(const LoopOptions& o) {
  RigidRansacOptions r;
  r.iterations = o.ransac_iterations;
  r.threshold_m = o.ransac_threshold_m;
  r.min_inliers = o.min_rigid_inliers;
  return r;
}

}  // namespace

LoopDetector::LoopDetector(const LoopOptions& options, const PinholeCamera& camera, map::Map& map,
                           place::KeyframeDatabase& database, const AtlasOptions& atlas)
    : options_(options), atlas_(atlas), camera_(camera), map_(map), database_(database) {
  options_.validate();
  atlas_.validate();
}

void LoopDetector::loopClosed(uint64_t kf_id) {
  last_loop_keyframe_ = kf_id;
  had_loop_ = true;
  groups_.clear();
  evidence_.clear();  // the correction moved the keyframes it was measured from
}

place::BowEncoding LoopDetector::encodingOf(map::Keyframe* kf) {
  place::BowEncoding e;
  auto bow = database_.bowVector(kf->id);
  auto features = database_.featureVector(kf->id);
  if (bow && features) {
    e.bow = std::move(*bow);
    e.features = std::move(*features);
    return e;
  }
  e = database_.encode(*kf->features, kf->status);
  database_.add(kf, e);
  return e;
}

std::optional<LoopMatch> LoopDetector::detect(map::Keyframe* kf) {
  std::shared_lock lock(map_.mutex());
  if (kf == nullptr || kf->bad) return std::nullopt;
  const place::BowEncoding encoding = encodingOf(kf);
  ++stats_.keyframes_checked;
  // Loops within a map wait for min_keyframes_between_loops (at the start, after a loop); merges
  // with another map do not.
  const uint64_t spacing = static_cast<uint64_t>(options_.min_keyframes_between_loops);
  const bool loops_allowed = !(kf->id < spacing || (had_loop_ && kf->id < last_loop_keyframe_ + spacing));

  std::vector<map::Keyframe*> candidates = consistentCandidates(kf, encoding.bow);
  if (!loops_allowed)
    std::erase_if(candidates, [&](const map::Keyframe* c) { return c->map_id == kf->map_id; });
  stats_.consistent_candidates += candidates.size();
  for (map::Keyframe* candidate : candidates) {
    if (std::optional<LoopMatch> match = accept(kf, verify(kf, candidate, encoding.features, false), false)) return match;
    ++stats_.rejected_geometry;
  }
  return std::nullopt;
}

std::optional<LoopMatch> LoopDetector::accept(const map::Keyframe* kf, std::optional<Fit> fit, bool end_of_run) {
  if (!fit) return std::nullopt;
  std::optional<LoopMatch> match;
  if (fit->confirmed) {
    match = std::move(fit->match);
    match->merge = match->loop->map_id != kf->map_id;
  } else {
    match = mergeFromEvidence(kf, *fit, end_of_run);
    if (match) ++stats_.merges_by_agreement;
  }
  if (!match) return std::nullopt;
  ++stats_.loops_detected;
  if (match->merge) ++stats_.merges_detected;
  return match;
}

std::optional<LoopMatch> LoopDetector::searchMergeAcrossMaps() {
  std::shared_lock lock(map_.mutex());
  std::map<int, std::vector<map::Keyframe*>> by_map;
  for (map::Keyframe* kf : map_.keyframes())
    if (!kf->bad) by_map[kf->map_id].push_back(kf);
  if (by_map.size() < 2) return std::nullopt;
  const int largest = std::max_element(by_map.begin(), by_map.end(), [](const auto& a, const auto& b) {
                        return a.second.size() < b.second.size();
                      })->first;
  for (const auto& [map_id, keyframes] : by_map) {
    if (map_id == largest) continue;
    std::set<uint64_t> own;
    for (const map::Keyframe* kf : keyframes) own.insert(kf->id);
    place::BowQueryOptions query;
    query.max_results = kFinalMergeCandidates;
    query.filter = [&own](uint64_t id) { return own.count(id) == 0; };
    for (map::Keyframe* kf : keyframes) {
      const place::BowEncoding encoding = encodingOf(kf);
      for (const place::KeyframeCandidate& c : database_.query(encoding.bow, query)) {
        if (c.keyframe->bad || c.keyframe->map_id == kf->map_id) continue;
        std::optional<LoopMatch> merge = accept(kf, verify(kf, c.keyframe, encoding.features, true), true);
        if (!merge) continue;
        spdlog::debug("loop: end of run: keyframe {} (map {}) found in map {} ({} inliers)", kf->id, kf->map_id,
                      c.keyframe->map_id, merge->inliers);
        return merge;
      }
    }
  }
  return std::nullopt;
}

std::optional<LoopMatch> LoopDetector::mergeFromEvidence(const map::Keyframe* kf, Fit& fit, bool end_of_run) {
  const SE3 T_wmap_c = kf->T_w_c();
  MergeEvidence now{kf->id, kf->timestamp, kf->map_id, fit.match.loop->map_id, fit.match.T_w_c_corrected * kf->T_c_w, {}};
  now.inliers.reserve(fit.inliers.size());
  for (const PointCorrespondence& c : fit.inliers) now.inliers.push_back({c.p_a, T_wmap_c * c.p_b, c.depth});
  RigidRansacOptions refit = ransacOptions(options_);
  refit.min_inliers = options_.min_loop_matches;
  // At the end of a run pieces may agree within the looser bound, from keyframes further apart.
  const double loose_m = atlas_.final_merge_agreement_m;
  const double loose_separation_s = std::max(kMapTransformAgreementS, loose_m / kSlowWalkerSpeedMS);
  const auto agree = [&](const MergeEvidence& e) {
    const double apart_s = std::abs(now.timestamp - e.timestamp);
    if (apart_s < kMapTransformAgreementS) return false;
    if (mapTransformsAgree(e.T_wother_wmap, now.T_wother_wmap)) return true;
    return end_of_run && apart_s >= loose_separation_s &&
           mapTransformsAgree(e.T_wother_wmap, now.T_wother_wmap, loose_m, atlas_.final_merge_agreement_deg);
  };
  for (const MergeEvidence& e : evidence_) {
    // Map ids that are still the same name the same worlds: a merged map's id goes away.
    if (e.map_id != now.map_id || e.other_map_id != now.other_map_id || e.keyframe_id == now.keyframe_id) continue;
    if (!agree(e)) continue;
    // Both fits' inliers together must make a loop's worth of matches under one transform.
    std::vector<PointCorrespondence> both = now.inliers;
    both.insert(both.end(), e.inliers.begin(), e.inliers.end());
    const RigidRansacResult joint = estimateRigidRansac(both, refit);
    spdlog::debug("loop: keyframe {} (map {}, {} inliers) agrees with keyframe {} ({}) on map {}: {} of {} inliers "
                  "together", kf->id, kf->map_id, now.inliers.size(), e.keyframe_id, e.inliers.size(), now.other_map_id,
                  joint.inlier_count, both.size());
    if (!joint.success) continue;
    LoopMatch match = std::move(fit.match);
    match.T_w_c_corrected = joint.T_a_b * T_wmap_c;
    // The keyframe's own matches that hold under the joint transform (the first now.inliers.size()).
    const std::vector<map::MapPoint*> fitted = std::move(match.matched_points);
    match.matched_points.assign(fitted.size(), nullptr);
    for (size_t k = 0; k < fit.inlier_features.size(); ++k) {
      const auto i = static_cast<size_t>(fit.inlier_features[k]);
      if (joint.inliers[k]) match.matched_points[i] = fitted[i];
    }
    match.inliers = joint.inlier_count;
    match.merge = true;
    return match;
  }
  spdlog::debug("loop: keyframe {} (map {}) fits map {} with {} inliers: kept as merge evidence", kf->id, kf->map_id,
                now.other_map_id, now.inliers.size());
  evidence_.push_back(std::move(now));
  if (evidence_.size() > kMaxMergeEvidence) evidence_.erase(evidence_.begin());
  ++stats_.merge_evidence;
  return std::nullopt;
}

std::vector<map::Keyframe*> LoopDetector::consistentCandidates(map::Keyframe* kf, const place::BowVector& bow) {
  const std::vector<map::Keyframe*> neighbours = map::bestCovisibles(kf, 0);
  const bool other_maps = map_.mapRecords().size() > 1;
  if (neighbours.empty() && !other_maps) return {};
  std::set<uint64_t> excluded{kf->id};
  double min_score = 1.0;
  for (map::Keyframe* nb : neighbours) {
    excluded.insert(nb->id);
    auto nb_bow = database_.bowVector(nb->id);
    const double s = nb_bow ? place::Vocabulary::score(bow, *nb_bow)
                            : place::Vocabulary::score(bow, database_.encode(*nb->features, nb->status).bow);
    min_score = std::min(min_score, s);
  }

  place::BowQueryOptions query;
  query.filter = [&excluded](uint64_t id) { return excluded.count(id) == 0; };
  std::map<uint64_t, double> scores;  // candidates at or above the neighbours' lowest score
  std::map<uint64_t, map::Keyframe*> by_id;
  for (const place::KeyframeCandidate& c : database_.query(bow, query)) {
    // A young map's own keyframes may not pass the floor (neighbours.empty(): no floor at all).
    const bool same_map = c.keyframe->map_id == kf->map_id;
    if (c.keyframe->bad || (same_map && (neighbours.empty() || c.score < min_score))) continue;
    scores[c.keyframe->id] = c.score;
    by_id[c.keyframe->id] = c.keyframe;
  }

  // Group each candidate with its best neighbours; a group scores what its members scored.
  struct Group {
    double score = 0;
    map::Keyframe* best = nullptr;
    double best_score = -1;
  };
  std::vector<Group> grouped;
  double best_group = 0;
  for (auto& [id, score] : scores) {
    Group g{score, by_id[id], score};
    for (map::Keyframe* nb : map::bestCovisibles(by_id[id], options_.group_size)) {
      auto it = scores.find(nb->id);
      if (it == scores.end()) continue;
      g.score += it->second;
      if (it->second > g.best_score) {
        g.best_score = it->second;
        g.best = nb;
      }
    }
    best_group = std::max(best_group, g.score);
    grouped.push_back(g);
  }
  std::vector<std::pair<double, map::Keyframe*>> representatives;
  std::set<uint64_t> seen;
  for (const Group& g : grouped)
    if (g.score >= options_.group_score_ratio * best_group && seen.insert(g.best->id).second)
      representatives.emplace_back(g.best_score, g.best);
  std::sort(representatives.begin(), representatives.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second->id < b.second->id;
  });

  // Consistency: a candidate's group (it and its neighbours) must share a keyframe with a group
  // that was a candidate for the previous keyframe; the streak length is carried over.
  std::vector<ConsistentGroup> next_groups;
  std::vector<map::Keyframe*> consistent;
  std::vector<bool> previous_extended(groups_.size(), false);
  for (auto& [score, candidate] : representatives) {
    ConsistentGroup group;
    group.keyframes.insert(candidate->id);
    for (map::Keyframe* nb : map::bestCovisibles(candidate, 0)) group.keyframes.insert(nb->id);
    int streak = 1;
    for (size_t g = 0; g < groups_.size(); ++g) {
      const bool shares = std::any_of(group.keyframes.begin(), group.keyframes.end(),
                                      [&](uint64_t id) { return groups_[g].keyframes.count(id) != 0; });
      if (!shares) continue;
      streak = std::max(streak, groups_[g].count + 1);
      previous_extended[g] = true;
    }
    group.count = streak;
    next_groups.push_back(std::move(group));
    const int needed = candidate->map_id == kf->map_id ? options_.min_consistent_keyframes
                                                       : atlas_.merge_min_consistent_keyframes;
    if (streak >= needed &&
        static_cast<int>(consistent.size()) < options_.max_candidates)
      consistent.push_back(candidate);
  }
  groups_.swap(next_groups);
  if (!consistent.empty())
    spdlog::debug("loop: keyframe {} has {} consistent candidate(s), best {}", kf->id, consistent.size(),
                  consistent.front()->id);
  return consistent;
}

std::optional<LoopDetector::Fit> LoopDetector::verify(map::Keyframe* kf, map::Keyframe* candidate,
                                                     const place::FeatureVector& kf_features, bool end_of_run) {
  if (candidate->bad) return std::nullopt;
  // A merge candidate may end as evidence (atlas.merge_evidence_min_inliers): lower bars on the way.
  const bool evidence_allowed = candidate->map_id != kf->map_id && atlas_.merge_evidence_min_inliers > 0;
  const map::FeatureSet& fa = *kf->features;

  // 1. Descriptor matches within shared vocabulary nodes: kf feature -> map point of the
  // candidate (for a merge, also of its best covisibles; ratio test within each keyframe).
  struct Pick {
    map::MapPoint* point = nullptr;
    int distance = feature::kMaxDescriptorDistance + 1;
    float angle_difference = 0;
  };
  std::vector<Pick> best_for_feature(fa.size());
  std::vector<map::Keyframe*> match_group{candidate};
  const int match_keyframes = candidate->map_id != kf->map_id ? atlas_.merge_match_keyframes : 1;
  if (match_keyframes > 1)
    for (map::Keyframe* nb : map::bestCovisibles(candidate, match_keyframes - 1)) match_group.push_back(nb);
  for (map::Keyframe* g : match_group) {
    if (g->bad) continue;
    auto g_features = database_.featureVector(g->id);
    if (!g_features) g_features = database_.encode(*g->features, g->status).features;
    const map::FeatureSet& fb = *g->features;
    place::forEachSharedNode(kf_features, *g_features, [&](place::NodeId, const std::vector<int>& rows_a,
                                                         const std::vector<int>& rows_b) {
      for (int ia : rows_a) {
        if (!kf->usable(ia)) continue;
        int best = feature::kMaxDescriptorDistance + 1, second = best, best_ib = -1;
        for (int ib : rows_b) {
          const map::MapPoint* p = g->points[ib];
          if (p == nullptr || p->bad) continue;
          const int d = feature::descriptorDistance(fa.descriptor(ia), fb.descriptor(ib));
          if (d < best) {
            second = best;
            best = d;
            best_ib = ib;
          } else if (d < second) {
            second = d;
          }
        }
        if (best_ib < 0 || best > options_.max_descriptor_distance) continue;
        if (static_cast<double>(best) >= options_.match_ratio * second) continue;
        Pick& pick = best_for_feature[static_cast<size_t>(ia)];
        if (best < pick.distance)
          pick = {g->points[best_ib], best, fa.keypoints[ia].angle - fb.keypoints[best_ib].angle};
      }
    });
  }
  // One feature per point: the closest descriptor (the lower feature index on ties).
  std::map<const map::MapPoint*, int> feature_for_point;
  for (size_t ia = 0; ia < best_for_feature.size(); ++ia) {
    const Pick& pick = best_for_feature[ia];
    if (pick.point == nullptr) continue;
    auto [it, inserted] = feature_for_point.emplace(pick.point, static_cast<int>(ia));
    if (!inserted && pick.distance < best_for_feature[static_cast<size_t>(it->second)].distance)
      it->second = static_cast<int>(ia);
  }
  std::vector<std::pair<int, map::MapPoint*>> pairs;  // (kf feature, loop point), by feature index
  std::vector<float> angle_differences;
  for (size_t ia = 0; ia < best_for_feature.size(); ++ia) {
    const Pick& pick = best_for_feature[ia];
    if (pick.point == nullptr || feature_for_point.at(pick.point) != static_cast<int>(ia)) continue;
    pairs.emplace_back(static_cast<int>(ia), pick.point);
    angle_differences.push_back(pick.angle_difference);
  }
  const std::vector<bool> rotation_ok = matching::orientationConsistent(angle_differences);

  std::vector<PointCorrespondence> correspondences;
  std::vector<std::pair<int, map::MapPoint*>> owners;  // kf feature, loop point
  for (size_t k = 0; k < pairs.size(); ++k) {
    if (!rotation_ok[k]) continue;
    Vec3 p_c;
    if (!cameraPoint(kf, pairs[k].first, camera_, p_c)) continue;
    map::MapPoint* p = pairs[k].second;
    correspondences.push_back({p->position, p_c, p_c.z()});
    owners.emplace_back(pairs[k].first, p);
  }
  const RigidRansacOptions ransac = ransacOptions(options_);
  RigidRansacOptions first_ransac = ransac;
  if (evidence_allowed) first_ransac.min_inliers = std::min(ransac.min_inliers, atlas_.merge_evidence_ransac_inliers);
  // Why a candidate fails (on fr1_desk every consistent candidate is a false place 1-2 m away
  // with < 25 descriptor matches; true revisits give 100+ inliers): one line per stage.
  const auto rejected = [&](const char* stage, int inliers) {
    size_t usable_a = 0, mapped_b = 0;
    for (size_t i = 0; i < fa.size(); ++i) usable_a += kf->usable(i) ? 1 : 0;
    for (const map::MapPoint* p : candidate->points) mapped_b += (p != nullptr && !p->bad) ? 1 : 0;
    spdlog::debug("loop: keyframe {} (map {}, t {:.3f}, {} static features) candidate {} (map {}, t {:.3f}, {} map points) "
                  "rejected at {}: {} descriptor matches, {} 3-D pairs, {} inliers",
                  kf->id, kf->map_id, kf->timestamp, usable_a, candidate->id, candidate->map_id, candidate->timestamp,
                  mapped_b, stage, pairs.size(), correspondences.size(), inliers);
    return std::nullopt;
  };
  if (static_cast<int>(correspondences.size()) < first_ransac.min_inliers) return rejected("matching", 0);
  const RigidRansacResult first = estimateRigidRansac(correspondences, first_ransac);
  if (!first.success) return rejected("RANSAC", first.inlier_count);

  // 2. Guided search: the candidate group's points projected with the estimated pose.
  std::vector<map::MapPoint*> matched(fa.size(), nullptr);
  std::set<const map::MapPoint*> used;
  for (size_t k = 0; k < owners.size(); ++k)
    if (first.inliers[k]) {
      matched[owners[k].first] = owners[k].second;
      used.insert(owners[k].second);
    }
  // The candidate group's points, by id (the confirmation below projects the same ones).
  std::vector<map::MapPoint*> loop_points;
  std::vector<map::Keyframe*> group{candidate};
  for (map::Keyframe* nb : map::bestCovisibles(candidate, options_.group_size)) group.push_back(nb);
  for (map::Keyframe* g : group)
    for (map::MapPoint* p : g->points)
      if (p != nullptr && !p->bad) loop_points.push_back(p);
  std::sort(loop_points.begin(), loop_points.end(),
            [](const map::MapPoint* a, const map::MapPoint* b) { return a->id < b->id; });
  loop_points.erase(std::unique(loop_points.begin(), loop_points.end()), loop_points.end());
  const SE3 T_c_w = first.T_a_b.inverse();
  const Vec3 center = first.T_a_b.translation();
  for (map::MapPoint* p : loop_points) {
    if (used.count(p) != 0) continue;
    Vec3 p_c;
    const int i = projectedMatch(kf, T_c_w, center, p, camera_, options_.projection_radius_px,
                                 options_.max_descriptor_distance, [&](int j) { return matched[j] == nullptr; }, p_c);
    if (i >= 0) matched[i] = p;
  }

  // 3. Refit on every match; the loop stands when enough agree.
  correspondences.clear();
  std::vector<int> features;
  for (size_t i = 0; i < matched.size(); ++i) {
    Vec3 p_c;
    if (matched[i] == nullptr || !cameraPoint(kf, static_cast<int>(i), camera_, p_c)) {
      matched[i] = nullptr;
      continue;
    }
    correspondences.push_back({matched[i]->position, p_c, p_c.z()});
    features.push_back(static_cast<int>(i));
  }
  RigidRansacOptions refit = ransac;
  refit.min_inliers = evidence_allowed ? std::min(options_.min_loop_matches, atlas_.merge_evidence_min_inliers)
                                       : options_.min_loop_matches;
  const RigidRansacResult final_fit = estimateRigidRansac(correspondences, refit);
  if (!final_fit.success) return rejected("guided search", final_fit.inlier_count);
  Fit fit;
  LoopMatch& match = fit.match;
  match.current = kf;
  match.loop = candidate;
  match.T_w_c_corrected = final_fit.T_a_b;
  match.matched_points.assign(fa.size(), nullptr);
  for (size_t k = 0; k < features.size(); ++k)
    if (final_fit.inliers[k]) {
      match.matched_points[features[k]] = matched[features[k]];
      fit.inliers.push_back(correspondences[k]);
      fit.inlier_features.push_back(features[k]);
    }
  match.ransac_inliers = first.inlier_count;
  match.inliers = final_fit.inlier_count;
  // Short of a loop's matches: evidence for a merge at most (see detect()), confirmed as a loop is.
  const bool short_of_loop = final_fit.inlier_count < options_.min_loop_matches;

  // 4. Confirmation from the keyframe's best covisibles: a transform fitted to a coincidence
  // (walkers, repeated texture) rarely also explains what the neighbouring keyframes see.
  if (options_.confirm_keyframes > 0) {
    const std::vector<map::Keyframe*> confirmers = map::bestCovisibles(kf, options_.confirm_keyframes);
    if (confirmers.empty()) {
      // A young map's first keyframe: only an agreeing fit from another keyframe can merge it.
      rejected("confirmation (no covisible keyframe)", final_fit.inlier_count);
      if (evidence_allowed) return fit;
      return std::nullopt;
    }
    // At the end of a run, a fit its covisibles nearly confirm may still be merge evidence.
    const int evidence_confirm_matches =
        evidence_allowed && end_of_run && atlas_.final_merge_min_confirm_matches > 0
            ? std::min(atlas_.final_merge_min_confirm_matches, options_.min_confirm_matches)
            : options_.min_confirm_matches;
    bool short_of_confirmation = false;
    for (map::Keyframe* nb : confirmers) {
      // The loop's transform carried to the neighbour through its pose relative to the keyframe.
      const SE3 T_w_nb = final_fit.T_a_b * kf->T_c_w * nb->T_w_c();
      const int confirmed = confirmedMatches(nb, T_w_nb, loop_points, ransac);
      if (confirmed < options_.min_confirm_matches) {
        spdlog::debug("loop: keyframe {} candidate {}: covisible keyframe {} confirms {} of {} needed matches",
                      kf->id, candidate->id, nb->id, confirmed, options_.min_confirm_matches);
        if (confirmed < evidence_confirm_matches) {
          ++stats_.rejected_confirmation;
          return rejected("confirmation", final_fit.inlier_count);
        }
        short_of_confirmation = true;
      }
    }
    if (short_of_confirmation) {
      rejected("confirmation (merge evidence)", final_fit.inlier_count);
      return fit;
    }
  }
  if (short_of_loop) {
    rejected("guided search (merge evidence)", final_fit.inlier_count);
    return fit;
  }
  fit.confirmed = true;
  return fit;
}

int LoopDetector::confirmedMatches(map::Keyframe* nb, const SE3& T_w_nb, const std::vector<map::MapPoint*>& loop_points,
                                   const RigidRansacOptions& ransac) const {
  const SE3 T_nb_w = T_w_nb.inverse();
  std::vector<bool> taken(nb->features->size(), false);
  int confirmed = 0;
  for (const map::MapPoint* p : loop_points) {
    Vec3 p_c;
    const int i = projectedMatch(nb, T_nb_w, T_w_nb.translation(), p, camera_, options_.projection_radius_px,
                                 options_.max_descriptor_distance, [&](int j) { return !taken[j]; }, p_c);
    // The neighbour's own depth must agree in 3-D, as the RANSAC inliers did.
    Vec3 seen_c;
    if (i < 0 || !cameraPoint(nb, i, camera_, seen_c)) continue;
    const PointCorrespondence c{p_c, seen_c, seen_c.z()};
    if ((p_c - seen_c).norm() > inlierThreshold(c, ransac)) continue;
    taken[i] = true;
    ++confirmed;
  }
  return confirmed;
}

}  // namespace desslam::loop
