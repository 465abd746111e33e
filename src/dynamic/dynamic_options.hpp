// dynamic.*: the dynamic-scene stages (dynamic/depth_checks.hpp, the tracker, the system).
#pragma once

#include <array>

#include "core/option_fields.hpp"

namespace desslam {

// dynamic.mode: which of DeS-SLAM's dynamic-scene stages run.
enum class DynamicMode {
  kOff,        // plain RGB-D SLAM
  kSemantic,   // every feature in the (person) mask is dropped
  kGeometric,  // depth checks (stages 1 and 2) on all features, no mask
  kFull,       // mask + stage 1 + stage 2
};
constexpr std::array<EnumName<DynamicMode>, 4> enumNames(DynamicMode) {
  return {{{DynamicMode::kOff, "off"}, {DynamicMode::kSemantic, "semantic"},
           {DynamicMode::kGeometric, "geometric"}, {DynamicMode::kFull, "full"}}};
}
// Whether the mode uses the semantic mask / the depth checks (stage 1 and 2).
constexpr bool usesMask(DynamicMode mode) { return mode == DynamicMode::kSemantic || mode == DynamicMode::kFull; }
constexpr bool usesDepthChecks(DynamicMode mode) {
  return mode == DynamicMode::kGeometric || mode == DynamicMode::kFull;
}

// dynamic.stage1_unmatched_policy: what stage 1 does with masked features it cannot check.
enum class UnmatchedPolicy { kKeep, kDrop };
constexpr std::array<EnumName<UnmatchedPolicy>, 2> enumNames(UnmatchedPolicy) {
  return {{{UnmatchedPolicy::kKeep, "keep"}, {UnmatchedPolicy::kDrop, "drop"}}};
}

struct DynamicOptions {
  DynamicMode mode = DynamicMode::kFull;
  double stage1_threshold = 0.12;   // |1 - d_proj/z_k| above this => dynamic (tracking)
  double stage2_threshold = 0.08;   // |z_r - d_r| / z_r above this => residual dynamic (keyframes)
  // The semantic mask is dilated by this radius. DeepLab labels a 257x257 image (one label per
  // ~2.5 px here) and a walking person is motion-blurred: with 5 px the matched features along
  // silhouettes dragged the Bonn crowd pose with the walkers (ATE 0.49 m), with 15 px 0.026 m.
  int mask_dilation_px = 15;
  // Real time: a mask carried forward from an older frame along optical flow (MaskPropagator)
  // follows the people only approximately (coarse flow, 257 px labels), so it grows by this much
  // more per frame of age, ...
  int carried_mask_growth_px = 12;
  // ... up to this much in all: under load the newest mask can be 10-20 frames old, and a mask
  // grown over the whole image leaves tracking nothing outside it in a crowd (the free-space test
  // catches the parts of walkers that left an old mask). Bonn crowd with emulated latencies
  // (3-10 frames, deterministic): cap 36 px -> ATE 0.030 m at 5 frames, cap 24 px -> 0.084 m.
  int carried_mask_max_growth_px = 36;
  // ... but the growth is a guess, and in a crowd it can cover the whole view (Bonn crowd in real
  // time: 97-100 % of the features in a mask 4-6 frames old, tracking lost for up to 0.6 s). The
  // growth shrinks (in steps of carried_mask_growth_px, down to none) until at least this share
  // of the frame's ORB features lies outside the mask; the free-space test and the mapping margin
  // still guard what the smaller mask lets in. 0 = always the full growth.
  double carried_mask_min_outside_share = 0.15;
  // A keyframe maps nothing within this many more pixels of the (dilated) mask; the frame itself
  // is still tracked with those features: track liberally, map conservatively. The network
  // misses legs and arms, and a late (real-time) mask lags behind the people. A keyframe left with
  // fewer than 100 mappable features is not made. Bonn crowd: emulated latencies of 3-10 frames
  // (deterministic, 4 runs) ATE median 0.034 -> 0.018 m; offline, threaded, 3 runs each: median
  // 0.037 -> 0.026 m. 0 = off.
  int mapping_margin_px = 40;
  // Stage 1 correspondence: a masked feature of frame k is matched to frame k-1's features by
  // descriptor within this window (pixels at level 0, scaled by the keypoint's level) around
  // where frame k-1 saw it if it were static; moving objects land a few pixels off.
  double stage1_search_radius_px = 20.0;
  int stage1_max_descriptor_distance = 100;  // Hamming distance accepted for a match
  double stage1_match_ratio = 0.9;           // best / second-best distance must be below this
  // Masked features without depth or without a depth-backed match in frame k-1: "keep" trusts
  // them, "drop" treats them as dynamic. On a person moving towards the camera most features find
  // no trustworthy match (synthetic test: ~2/3), so "keep" leaves many of them in.
  UnmatchedPolicy stage1_unmatched_policy = UnmatchedPolicy::kDrop;
  // Policy "drop" only: a masked feature in the ring a late mask's growth adds (beyond the
  // network's mask dilated by mask_dilation_px) dropped for want of a match in the reference frame
  // (or of depth there) stays a candidate for the local-map search, which takes it only where a
  // map point lies within stage1_threshold of its depth, at its appearance. A frame 0.2 s back
  // matches few features in a fast sweep (h107 composite, 5-frame-old masks grown to 51 px: 60-70 %
  // of the masked features unmatched, 3-7 % consistent), so the static background a grown mask
  // covers was lost to tracking. Inside the network's mask and its dilation a map point may be a
  // person's (mapped while the network missed them), so not there.
  bool stage1_map_check = true;
  int stage2_keyframes = 5;  // at most this many co-visible keyframes vote per map point
  // Stage 1 compares frame k with the newest tracked frame at least this old (0: always k-1).
  // At 30 Hz a walking person changes depth by ~2 % between consecutive frames, far below the
  // 12 % threshold; a few tenths of a second make the motion visible while a person sitting
  // still stays consistent over any interval.
  double stage1_min_interval_s = 0.2;
  // A masked feature whose matched 3-D point re-projects farther than this (pixels at level 0,
  // scaled by its level) from it has moved in the image: dynamic, whatever its depth says.
  double stage1_max_reprojection_px = 4.0;
  // When people fill most of the view, the ORB budget (orb.num_features, spread evenly over the
  // image) leaves few features on the static background, and tracking is lost once stage 1 has
  // removed the people's. A frame with fewer features than this outside its (dilated) mask gets
  // more extracted outside it (duplicates skipped). While tracking is lost the target is at least
  // atlas.min_initial_features features with depth, what a new map needs. 0 = off.
  int min_features_outside_mask = 500;
  // Full mode: features outside the mask go through the correspondence-free free-space test
  // (dynamic::freeSpaceViolations) against the stage-1 reference frame and the reference
  // keyframe: the network misses legs and arms, and a late (real-time) mask misses whoever
  // entered the view since.
  bool free_space_outside_mask = true;
  // A frame's mask also covers the previous segmentation's mask carried to it along the optical
  // flow. The network drops a person for single frames (motion blur, a torso filling the view,
  // a body cut by the image border); a person does not vanish in 1/30 s. Such a dropout let a
  // new map start and a relocalisation succeed on people (fr1_desk composite with Bonn's crowd
  // frames 300-500: 30-40 % of the image masked on one frame, 90 % on the frames around it).
  // Stage 1 still keeps the static features it covers.
  bool mask_hold_previous = true;

  static constexpr const char* kSection = "dynamic";
  template <class V> void fields(V& v) {
    v("mode", mode); v("stage1_threshold", stage1_threshold); v("stage2_threshold", stage2_threshold);
    v("mask_dilation_px", mask_dilation_px); v("carried_mask_growth_px", carried_mask_growth_px);
    v("carried_mask_max_growth_px", carried_mask_max_growth_px);
    v("carried_mask_min_outside_share", carried_mask_min_outside_share);
    v("mapping_margin_px", mapping_margin_px);
    v("stage1_search_radius_px", stage1_search_radius_px);
    v("stage1_max_descriptor_distance", stage1_max_descriptor_distance);
    v("stage1_match_ratio", stage1_match_ratio); v("stage1_unmatched_policy", stage1_unmatched_policy);
    v("stage1_map_check", stage1_map_check); v("stage2_keyframes", stage2_keyframes);
    v("stage1_min_interval_s", stage1_min_interval_s);
    v("stage1_max_reprojection_px", stage1_max_reprojection_px);
    v("min_features_outside_mask", min_features_outside_mask);
    v("free_space_outside_mask", free_space_outside_mask); v("mask_hold_previous", mask_hold_previous);
  }
  void validate() const;
};

}  // namespace desslam
