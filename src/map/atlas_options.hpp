// atlas.*: several maps in one run. Read by tracking and loop closing; here in the map library,
// the lowest one both link.
#pragma once

#include <cmath>

#include "core/option_fields.hpp"
#include "core/se3.hpp"

namespace desslam {

// Continuity (tracking/tracker.hpp, loop/loop_closer.hpp): when a map cannot be started or
// tracking is lost, a new map starts instead of waiting; place recognition merges maps again.
struct AtlasOptions {
  bool enabled = true;  // off: lost stays lost until relocalisation succeeds (one map)
  // A map starts only from a frame with this many static, depth-backed features (ORB-SLAM2's RGB-D
  // start asks for 500), spread over at least min_initial_cells of a 4 x 4 image grid (a corner
  // left by a crowd is too weak an anchor); otherwise the next frame is tried.
  int min_initial_features = 500;
  int min_initial_cells = 6;
  // Relocalisation (against every map) is tried for this long after a loss; then a new map starts
  // at the current frame. 0: at the first frame relocalisation fails.
  double new_map_after_lost_s = 0.1;
  // A new map starting at most this long after the last tracked frame first drops the static
  // features that the last map's reference keyframe saw through (dynamic::freeSpaceViolations at
  // the bridged pose; dynamic modes full and geometric): a person filling
  // the view is often missed by the network (a torso close up), and a map started on them tracks
  // the person (fr1_xyz composite: a map started on an unmasked sweater, its frames 8-15 cm off
  // after the merge). The bridged pose is a few centimetres off within this time. 0 = never.
  double start_free_space_check_s = 0.6;
  // A map lost before it has this many keyframes gets no relocalisation time: a new one starts at
  // once (a young map has too little to relocalise against).
  int young_map_keyframes = 5;
  // For this long after a map starts at a loss (seconds; 0 = off), each frame tracked in it is
  // also relocalised against the other maps (Tracker::findInOtherMap); found in one twice, at
  // least 0.15 s apart, with the same transform between the maps, the two are merged by loop
  // closing at a keyframe made there. A crowd that covered the view for a moment often leaves the
  // camera where the old map is, but place recognition alone rarely merges a map started in a
  // crowd: it must recognise two of that map's keyframes in a row.
  double other_map_search_s = 2.0;
  // A keyframe recognised in another map must recur over this many consecutive keyframes before
  // the maps are merged (loop.min_consistent_keyframes applies to loops within a map).
  int merge_min_consistent_keyframes = 2;
  // A merge's first, BoW-guided matching pairs the keyframe's features with the map points of the
  // candidate and its best covisibles, this many keyframes in all (1: the candidate alone): a map
  // started in a crowd is often seen again only 20-30 degrees apart, by keyframes holding 100-300
  // map points, too few alone. Loops within a map match the candidate alone: there a missed loop
  // costs some drift, while a wider match closed 6 false loops on Bonn crowd (walkers, presumably).
  int merge_match_keyframes = 5;
  // A merge candidate whose fit falls short of loop.min_loop_matches after the guided search but
  // still has this many inliers (and is confirmed by the keyframe's covisibles as a loop is, where
  // it has any) is kept as evidence. Two such fits, from keyframes at least kMapTransformAgreementS
  // apart, that give the same transform between the two maps (kMapTransformAgreementM/Deg), and
  // whose inliers refitted together reach loop.min_loop_matches under one transform, merge them by
  // that transform. A map revisited 20-40 degrees off its old views, or in a crowd, gives 25-39
  // inliers per keyframe where a loop needs 40 (crowded fr1_desk composites: maps that saw the same
  // desk 0.2 m apart stayed apart), while fits to walkers or coincidences do not repeat. The first
  // RANSAC of such a candidate needs merge_evidence_ransac_inliers (instead of
  // loop.min_rigid_inliers) to go on to the guided search. 0 = off.
  int merge_evidence_min_inliers = 25;
  int merge_evidence_ransac_inliers = 12;
  // At the end of a run, the maps still apart are searched for each other: every keyframe of each
  // but the largest against the other maps' keyframes its bag of words ranks best, verified as a
  // merge online is (loop/loop_detector.hpp: searchMergeAcrossMaps), and merged one after another
  // before the final bundle adjustment. Online, a place seen again that BoW ranks below others for
  // two keyframes in a row never becomes a candidate.
  bool final_merge_search = true;
  // That search's merge evidence (online merges keep the bars above): a fit whose keyframe's
  // covisibles each confirm at least final_merge_min_confirm_matches of loop.min_confirm_matches
  // is kept as evidence, and two pieces agree within final_merge_agreement_m / _deg. At the end
  // both maps are complete and no tracking depends on the merge, which pose graph and global BA
  // then settle; a map made in a crowd is bent by a few centimetres and degrees over its length
  // (crowded fr1_desk composites: two keyframes of a 1 s side map fitted the main map 11-15 cm and
  // 4-8 degrees apart, their covisibles confirming 14-19 of 20 matches), while fits to walkers or
  // coincidences land metres and tens of degrees apart. Two pieces that agree only within these
  // (not within the online 5 cm / 3 degrees) must come from keyframes at least
  // final_merge_agreement_m / kSlowWalkerSpeedMS apart in time (0.3 s; online 0.15 s), so that a
  // walker's motion between them exceeds the bound. final_merge_min_confirm_matches 0 = the
  // online confirmation; 0.05 m / 3 degrees = the online agreement.
  int final_merge_min_confirm_matches = 10;
  double final_merge_agreement_m = 0.15;
  double final_merge_agreement_deg = 8.0;

  static constexpr const char* kSection = "atlas";
  template <class V> void fields(V& v) {
    v("enabled", enabled); v("min_initial_features", min_initial_features);
    v("min_initial_cells", min_initial_cells); v("new_map_after_lost_s", new_map_after_lost_s);
    v("start_free_space_check_s", start_free_space_check_s); v("young_map_keyframes", young_map_keyframes);
    v("other_map_search_s", other_map_search_s);
    v("merge_min_consistent_keyframes", merge_min_consistent_keyframes);
    v("merge_match_keyframes", merge_match_keyframes);
    v("merge_evidence_min_inliers", merge_evidence_min_inliers);
    v("merge_evidence_ransac_inliers", merge_evidence_ransac_inliers);
    v("final_merge_search", final_merge_search);
    v("final_merge_min_confirm_matches", final_merge_min_confirm_matches);
    v("final_merge_agreement_m", final_merge_agreement_m);
    v("final_merge_agreement_deg", final_merge_agreement_deg);
  }
  void validate() const;
};

// Two estimates of the transform between two maps (tracking's sightings of another map, loop
// closing's merge evidence) agree when they differ by at most this much and were taken at least
// kMapTransformAgreementS apart: walkers' features that the masks missed can make one
// consistent-looking fit, but they move on within that time.
inline constexpr double kMapTransformAgreementM = 0.05;
inline constexpr double kMapTransformAgreementDeg = 3.0;
inline constexpr double kMapTransformAgreementS = 0.15;
// Two such estimates agreeing within a looser bound (atlas.final_merge_agreement_m) must be taken
// at least that bound over this speed apart: a walker at half a usual walking pace moves further.
inline constexpr double kSlowWalkerSpeedMS = 0.5;
// Whether two estimates of the same transform between two maps agree (by default the distance and
// angle above).
inline bool mapTransformsAgree(const SE3& T_a, const SE3& T_b, double max_m = kMapTransformAgreementM,
                               double max_deg = kMapTransformAgreementDeg) {
  const SE3 difference = T_a.inverse() * T_b;
  return difference.translation().norm() <= max_m && difference.rotationAngle() <= max_deg * M_PI / 180;
}

}  // namespace desslam
