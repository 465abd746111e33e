// Loop detection (place recognition + geometric verification) for one new keyframe at a time:
//  1. candidates from the keyframe database scoring at least the lowest score of the keyframe's
//     covisible neighbours, the neighbours themselves excluded;
//  2. candidates grouped with their best covisible keyframes; weak groups dropped;
//  3. a group must recur over `min_consistent_keyframes` consecutive keyframes (groups linked
//     by sharing a keyframe);
//     candidates in another map of the atlas (a merge) skip step 1's score floor (a young map's
//     few neighbours look alike) and need atlas.merge_min_consistent_keyframes; the geometric
//     check below is the same, except that a merge candidate falling short of its bars with at
//     least atlas.merge_evidence_min_inliers is kept as evidence: two agreeing ones merge the maps;
//  4. descriptor matches (within vocabulary nodes) between the keyframe's features and the
//     candidate's map points, rigid SE(3) RANSAC on 3-D-3-D pairs (depth gives the scale),
//     guided search by projection of the candidate group's points, refit.
//
// Locking: detect() takes the Map lock shared for its whole (short: BoW queries, matching,
// RANSAC) run and never exclusively; the database has its own mutex, always taken after the Map
// lock. One thread calls detect() (the loop-closing thread): the consistency state is unguarded.
#pragma once

#include <cstdint>
#include <optional>
#include <set>
#include <vector>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "loop/loop_options.hpp"
#include "loop/rigid_estimation.hpp"
#include "map/atlas_options.hpp"
#include "map/map.hpp"
#include "place/keyframe_database.hpp"

namespace desslam::loop {

struct LoopMatch {
  map::Keyframe* current = nullptr;  // the new keyframe
  map::Keyframe* loop = nullptr;     // the old keyframe it sees again
  // Pose of the current keyframe in the loop keyframe's (old, undrifted) world.
  SE3 T_w_c_corrected;
  // Per feature of `current`: the loop group's map point it matched (inliers only), or null.
  std::vector<map::MapPoint*> matched_points;
  int ransac_inliers = 0;  // from descriptor matching alone
  int inliers = 0;         // after guided search and refit
  bool merge = false;      // the loop keyframe lies in another map of the atlas
  bool from_tracking = false;  // suggested by tracking (LoopCloser::suggestMerge), not recognised here
};

struct LoopDetectionStats {
  size_t keyframes_checked = 0;
  size_t consistent_candidates = 0;  // candidates that passed the consistency test
  size_t rejected_geometry = 0;      // ... but failed RANSAC, the guided search or the confirmation
  size_t rejected_confirmation = 0;  // of those, fitted but not confirmed by the keyframe's covisibles
  size_t loops_detected = 0;
  size_t merges_detected = 0;        // of those, in another map
  size_t merge_evidence = 0;         // merge candidates kept as evidence (short of the bars, see above)
  size_t merges_by_agreement = 0;    // merges from two agreeing pieces of evidence
};

class LoopDetector {
 public:
  LoopDetector(const LoopOptions& options, const PinholeCamera& camera, map::Map& map, place::KeyframeDatabase& database,
               const AtlasOptions& atlas = {});

  // Checks one keyframe (in keyframe order). Adds it to the database when it is not there yet
  // (local mapping normally has). Returns a verified loop, or nothing.
  std::optional<LoopMatch> detect(map::Keyframe* kf);
  // The end of a run: each keyframe of every map but the one with the most keyframes against the
  // other maps' keyframes its bag of words ranks best (kFinalMergeCandidates), each verified as a
  // merge candidate online is (a confirmed fit, or two agreeing pieces of evidence, with the
  // evidence bars of atlas.final_merge_*), without the consistency over consecutive keyframes
  // (step 3): online, a revisit that BoW ranks below other places never becomes a candidate. The
  // first merge found, or nothing.
  std::optional<LoopMatch> searchMergeAcrossMaps();
  // A loop ending at keyframe `kf_id` was closed: detection pauses for
  // min_keyframes_between_loops keyframes and the consistency state starts over.
  void loopClosed(uint64_t kf_id);

  const LoopDetectionStats& stats() const { return stats_; }

 private:
  struct ConsistentGroup {
    std::set<uint64_t> keyframes;
    int count = 0;  // consecutive keyframes this group was a candidate in
  };

  std::vector<map::Keyframe*> consistentCandidates(map::Keyframe* kf, const place::BowVector& bow);
  // A fitted candidate: `confirmed` when it clears every bar of a loop; otherwise (merge candidates
  // only) evidence with at least atlas.merge_evidence_min_inliers.
  struct Fit {
    LoopMatch match;
    bool confirmed = false;
    // The fit's inliers: candidate-world point (p_a) and the keyframe's camera point (p_b), and the
    // keyframe feature of each.
    std::vector<PointCorrespondence> inliers;
    std::vector<int> inlier_features;
  };
  // end_of_run: called by searchMergeAcrossMaps, whose evidence bars are atlas.final_merge_*.
  std::optional<Fit> verify(map::Keyframe* kf, map::Keyframe* candidate, const place::FeatureVector& kf_features,
                            bool end_of_run);
  // The loop or merge a fit makes (confirmed, or merged from agreeing evidence), counted in the
  // stats; nothing otherwise. Map lock held (shared).
  std::optional<LoopMatch> accept(const map::Keyframe* kf, std::optional<Fit> fit, bool end_of_run);
  // A merge candidate's fit short of a loop's bars, with the evidence kept from earlier keyframes:
  // when one of them agrees on the transform between the two maps (kMapTransformAgreement*; at the
  // end of a run atlas.final_merge_agreement_*) and the inliers of both, refitted together, reach
  // loop.min_loop_matches, the merge; else the fit is kept as evidence. Map lock held (shared).
  struct MergeEvidence {
    uint64_t keyframe_id = 0;
    Timestamp timestamp = 0;
    int map_id = -1;        // the keyframe's map
    int other_map_id = -1;  // the candidate's
    SE3 T_wother_wmap;
    std::vector<PointCorrespondence> inliers;  // p_a in the other map's world, p_b in this map's
  };
  std::optional<LoopMatch> mergeFromEvidence(const map::Keyframe* kf, Fit& fit, bool end_of_run);
  // Features of `nb` that match one of `loop_points` where the pose T_w_nb projects it, with the
  // descriptor within max_descriptor_distance and nb's 3-D reading within the RANSAC tolerance.
  int confirmedMatches(map::Keyframe* nb, const SE3& T_w_nb, const std::vector<map::MapPoint*>& loop_points,
                       const RigidRansacOptions& ransac) const;
  place::BowEncoding encodingOf(map::Keyframe* kf);

  LoopOptions options_;
  AtlasOptions atlas_;
  PinholeCamera camera_;
  map::Map& map_;
  place::KeyframeDatabase& database_;
  std::vector<ConsistentGroup> groups_;
  std::vector<MergeEvidence> evidence_;  // oldest first, at most kMaxMergeEvidence
  uint64_t last_loop_keyframe_ = 0;
  bool had_loop_ = false;
  LoopDetectionStats stats_;
};

}  // namespace desslam::loop
