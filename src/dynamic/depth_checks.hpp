// The two depth-consistency checks of DeS-SLAM, as pure functions (plain data in and out, no
// locking; the caller holds whatever lock its inputs need).
//
// Stage 1 (tracking, frame k against frame k-1): features inside the (dilated) semantic mask are
// tested; a feature whose depth does not agree with where its frame k-1 counterpart says it
// should be is dynamic. A person sitting still passes and keeps their features.
//
// Stage 2 (local mapping, keyframes): a map point that survived stage 1 is projected into its
// best co-visible keyframes; if the depth those keyframes observed disagrees with the optimised
// point in the majority of them, it is a residual dynamic point.
//
// Depth images are CV_32F metres, 0 (or any value <= 0) = no reading, registered to the raw
// (distorted) RGB image. Geometry uses undistorted pixels (FeatureSet::uv), depth look-ups
// distort back first.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "dynamic/dynamic_options.hpp"
#include "map/features.hpp"

namespace desslam::dynamic {

// |1 - predicted / observed|: relative depth disagreement, measured against what the sensor saw.
// Stage 1: observed = z_k, predicted = d_proj. Stage 2: observed = z_r, predicted = d_r, which is
// the same as |z_r - d_r| / z_r. Requires observed > 0.
double relativeDepthResidual(double observed, double predicted);

// residual > threshold (strictly: a residual exactly at the threshold is consistent).
bool exceeds(double residual, double threshold);

// Median of the valid (> 0) depths in the 3x3 window around pixel (x, y) of a CV_32F depth image;
// 0 when none is valid or (x, y) is outside. The median ignores a lone flying pixel at a depth edge.
double medianDepth3x3(const cv::Mat& depth_m, int x, int y);

// ---------------------------------------------------------------------------------------------
// Stage 1

// Per feature of frame k.
enum class Stage1Outcome : uint8_t {
  kNotChecked = 0,  // outside the mask: stage 1 does not look at it
  kConsistent = 1,  // in the mask, depth agrees with frame k-1: kept
  kDynamic = 2,     // in the mask, a residual exceeds stage1_threshold: removed
  kNoDepth = 3,     // in the mask, no depth at the feature or at its frame k-1 match
  kUnmatched = 4,   // in the mask, no descriptor match in frame k-1
};

struct Stage1Input {
  const map::FeatureSet* current = nullptr;  // frame k
  const cv::Mat* current_depth = nullptr;    // frame k, CV_32F metres (for the sideways residual)
  // Frame k's semantic mask, CV_8U, nonzero = dynamic class, raw pixels, image-sized. Null or
  // empty: every feature is checked (the geometric-only mode).
  const cv::Mat* mask = nullptr;
  bool mask_is_dilated = false;  // false: runStage1 dilates it by options.mask_dilation_px
  const map::FeatureSet* previous = nullptr;  // frame k-1 (its depth per feature is used)
  // Relative pose, frame k-1 -> frame k: the best estimate the caller has (the motion-model
  // prediction refined on the features outside the mask).
  SE3 T_k_km1;
  // Optional: the caller's own correspondences, previous feature index per current feature
  // (-1 = none); when given, no descriptor matching is done. Otherwise a masked feature with
  // depth is matched by descriptor (feature::descriptorDistance) among frame k-1's features on
  // neighbouring pyramid levels, in a window of stage1_search_radius_px x level scale around
  // where frame k-1 would have seen it were it static; accepted when the distance is at most
  // stage1_max_descriptor_distance, passes the ratio test (stage1_match_ratio) and is mutual
  // (searching back from the match finds the feature again).
  const std::vector<int>* previous_match = nullptr;
};

// Both residuals, per feature (NaN where not computed):
//   forward  = |1 - d_proj / z_k|: d_proj is the depth in frame k of the frame k-1 point moved by
//              T_k_km1, z_k the feature's own depth. Catches motion along the viewing ray.
//   sideways = |1 - d_proj / z(x')|: z(x') is frame k's depth (3x3 median) at the pixel x' where
//              the moved frame k-1 point projects. An object moving across the image keeps its
//              depth (forward ~ 0), but x' then shows whatever is now where it was (usually the
//              background), so the second residual catches it. NaN when x' is outside the image
//              or has no valid depth (then only the forward residual decides).
// A feature is dynamic when EITHER residual exceeds stage1_threshold: each catches one kind of
// motion and, for a static point with a good pose, both are ~0 (x' lands on the feature itself).
// The sideways residual only counts when z(x') > d_proj (the sensor sees THROUGH where the point
// should be, the stage 2 occlusion rule): a nearer surface at x' merely hides the point, which
// happens to static background beside a person's silhouette whenever x' falls a pixel onto the
// person. residual_sideways is reported either way; `residual` holds what decided.
// Note: stage 1 sees depth change between the two frames only; at 30 Hz a person walking at
// 1 m/s 1.5 m away changes depth by ~2 % per frame, far below 12 %.
struct Stage1Result {
  std::vector<Stage1Outcome> outcome;
  std::vector<uint8_t> in_mask;    // 1 if the feature lies in the (dilated) mask
  // Final decision per feature: kDynamic, plus kNoDepth/kUnmatched under policy "drop".
  std::vector<uint8_t> dynamic;
  std::vector<int> previous_index;  // matched feature of frame k-1, -1 if none
  std::vector<double> residual_forward, residual_sideways;
  std::vector<double> residual;     // the larger residual that counts (NaN if none computed)
  int in_mask_count = 0, consistent_count = 0, dynamic_count = 0, no_depth_count = 0, unmatched_count = 0;
  int removed_count = 0;            // features with dynamic = 1
};

// Throws InputError when a required pointer is null, the mask/depth are of the wrong type or
// size, or previous_match has the wrong length.
Stage1Result runStage1(const Stage1Input& input, const PinholeCamera& camera, const DynamicOptions& options);

// ---------------------------------------------------------------------------------------------
// Stage 1, outside the mask: the free-space test
//
// The network labels a 257x257 image and misses parts of people (legs against the floor, an arm,
// someone at the image border); features there lie outside the mask, and dragged the Bonn crowd
// pose while the camera stood still. Descriptor correspondence cannot vouch for them (a leg moves
// further in stage1_min_interval_s than any search window), so this test needs none: were the
// feature's 3-D point (frame k, depth z_k) static, the reference frame would have seen it at
// depth d_ref at pixel x'. When even the NEAREST valid reading in a 5x5 window around x' is
// farther, |1 - d_ref / z_near| > stage1_threshold with z_near > d_ref, the reference frame saw
// through the place where the point is now: it moved there. A nearer reading (something in front)
// is no evidence, as in stage 2; taking the nearest reading keeps a static point at a depth edge,
// a pixel or two of pose error away from the background, from being called dynamic.
struct FreeSpaceInput {
  const map::FeatureSet* current = nullptr;
  const cv::Mat* reference_depth = nullptr;  // CV_32F metres, raw pixels divided by depth_scale
  int depth_scale = 1;                       // 2: a keyframe's half-resolution depth
  SE3 T_ref_k;                               // frame k -> reference frame
  const std::vector<uint8_t>* test = nullptr;  // per feature of current: 1 = test it (null: all)
};

// Per feature: 1 when the reference frame saw through its point (dynamic). Features without depth,
// not to be tested, behind the reference camera, outside its image or without a reading there
// get 0. Throws InputError for a missing input or a wrong depth type / test length.
std::vector<uint8_t> freeSpaceViolations(const FreeSpaceInput& input, const PinholeCamera& camera,
                                         const DynamicOptions& options);

// ---------------------------------------------------------------------------------------------
// Stage 2

// Keyframes keep a half-resolution depth image for stage 2. Chosen format: CV_32F metres (the
// in-memory depth convention, no depth_factor to carry around; 320x240x4 = 300 KB per
// keyframe). Each output pixel takes the NEAREST (smallest) valid depth of its 2x2 block rather
// than an average, which would invent depths between foreground and background at edges:
// the foreground reading makes a background point look occluded (ignored, see below) instead of
// moved, so an edge pixel can never vote a static point out. 0 where the block has no reading.
cv::Mat makeHalfResolutionDepth(const cv::Mat& depth_m);

// Depth (metres) of a half-resolution image at the full-resolution undistorted pixel uv: 3x3
// median (medianDepth3x3) around the half-resolution pixel covering it. 0 when none.
double sampleHalfResolutionDepth(const cv::Mat& half_depth, const Vec2& uv, const PinholeCamera& camera);

struct KeyframeDepthView {
  SE3 T_c_w;                          // the keyframe's (optimised) pose
  const cv::Mat* half_depth = nullptr;  // from makeHalfResolutionDepth
};

// Occlusion rule. With d_r the point's depth in keyframe r and z_r the depth observed there:
//   z_r > d_r and |z_r - d_r| / z_r > threshold: the sensor saw THROUGH the point's position
//       (something farther away is visible where the point should be): the point was not there,
//       a vote for "dynamic".
//   z_r < d_r and |z_r - d_r| / z_r > threshold: something is IN FRONT of the point (a person
//       passing in front of static background): the point is occluded in r, which says nothing
//       about it; keyframe r abstains (counted in keyframes_occluded, not in keyframes_checked).
//   otherwise: consistent, a vote for "static".
// Keyframes where the point is behind the camera, projects outside the image or has no depth
// reading are skipped. The point is a residual dynamic when at least one keyframe voted and
// strictly more than half of the votes say dynamic (a tie keeps it).
struct Stage2Decision {
  bool dynamic = false;
  int keyframes_checked = 0;       // votes (consistent + inconsistent)
  int keyframes_inconsistent = 0;  // votes for dynamic
  int keyframes_occluded = 0;      // abstained
  double median_residual = 0;      // over the votes; 0 when none
};

// views: the point's best co-visible keyframes, best first (e.g. a keyframe's ordered
// connections, without keyframes in which the point was measured: there it agrees by
// construction). They are gone through in order until options.stage2_keyframes votes are cast.
Stage2Decision checkStage2(const Vec3& point_w, const std::vector<KeyframeDepthView>& views,
                           const PinholeCamera& camera, const DynamicOptions& options);

}  // namespace desslam::dynamic
