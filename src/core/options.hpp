// Options structs of every stage: defaults here, values from YAML (io/config.hpp), each with
// validate() that throws ConfigError naming the bad key ("section.key").
//
// Each struct lists its keys once in fields(v), v(key, member): the YAML loader, the report
// writer and unknown-key detection all use that list, so a new option is added in one place.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/error.hpp"

namespace desslam {

// Throws ConfigError "<section>.<key> = <value>: <requirement>" unless lo <= value <= hi.
void requireInRange(const char* section, const char* key, double value, double lo, double hi);
// Throws ConfigError "<section>.<key>: <message>" unless ok.
void requireThat(bool ok, const char* section, const char* key, const std::string& message);

// Options whose value is one of a few names (dynamic.mode: off | semantic | geometric | full) are
// enum classes. Each lists its names once, in a function enumNames(E) beside the enum (found by
// argument-dependent lookup): the YAML reader parses them (an unknown name is an error listing the
// allowed ones), report.json writes them, and nothing else compares strings.
template <class E> struct EnumName {
  E value;
  const char* name;
};
template <class E>
concept NamedEnum = std::is_enum_v<E> && requires { enumNames(E{}); };

template <NamedEnum E> const char* nameOf(E value) {
  for (const auto& entry : enumNames(E{}))
    if (entry.value == value) return entry.name;
  return "?";  // not reachable for a value the enum lists
}
template <NamedEnum E> std::optional<E> enumFromName(std::string_view name) {
  for (const auto& entry : enumNames(E{}))
    if (name == entry.name) return entry.value;
  return std::nullopt;
}
template <NamedEnum E> std::vector<std::string> enumNameList() {
  std::vector<std::string> names;
  for (const auto& entry : enumNames(E{})) names.emplace_back(entry.name);
  return names;
}

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

// semantic.segmenter: where the masks come from.
enum class SegmenterKind { kDeepLab, kMaskDir, kNone };
constexpr std::array<EnumName<SegmenterKind>, 3> enumNames(SegmenterKind) {
  return {{{SegmenterKind::kDeepLab, "deeplab"}, {SegmenterKind::kMaskDir, "mask_dir"}, {SegmenterKind::kNone, "none"}}};
}

// semantic.backend: the inference library of the deeplab segmenter.
enum class SegmentationBackend { kOpenCv, kXnnpack };
constexpr std::array<EnumName<SegmentationBackend>, 2> enumNames(SegmentationBackend) {
  return {{{SegmentationBackend::kOpenCv, "opencv"}, {SegmentationBackend::kXnnpack, "xnnpack"}}};
}

struct CameraOptions {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 640, height = 480;
  std::array<double, 5> distortion{0, 0, 0, 0, 0};  // k1 k2 p1 p2 k3 (OpenCV order)
  double depth_factor = 5000.0;  // raw 16-bit depth value per metre (TUM/Bonn: 5000)
  double fps = 30.0;
  // Depth residuals are expressed as a virtual stereo disparity bf/z (pixels), as for RGB-D
  // keypoints in the ORB-SLAM2 paper; bf = fx * depth_baseline (Kinect-like sensors: ~8 cm).
  double depth_baseline = 0.08;  // metres

  // The virtual stereo baseline times fx (pixel * metres): the one place it is computed.
  double bf() const { return fx * depth_baseline; }

  static constexpr const char* kSection = "camera";
  template <class V> void fields(V& v) {
    v("fx", fx); v("fy", fy); v("cx", cx); v("cy", cy); v("width", width); v("height", height);
    v("distortion", distortion); v("depth_factor", depth_factor); v("fps", fps); v("depth_baseline", depth_baseline);
  }
  void validate() const;
};

struct OrbOptions {
  int num_features = 1000;
  int num_levels = 8;
  double scale_factor = 1.2;
  int initial_fast_threshold = 20;  // tried first in each cell
  int min_fast_threshold = 7;       // fallback in cells where the first finds nothing
  int cell_size = 35;               // pixel size of the FAST detection grid cells

  static constexpr const char* kSection = "orb";
  template <class V> void fields(V& v) {
    v("num_features", num_features); v("num_levels", num_levels); v("scale_factor", scale_factor);
    v("initial_fast_threshold", initial_fast_threshold); v("min_fast_threshold", min_fast_threshold);
    v("cell_size", cell_size);
  }
  void validate() const;
};

struct TrackingOptions {
  double min_depth = 0.1;          // metres; closer readings are ignored
  double max_depth = 4.0;          // metres; features beyond have no depth-backed 3-D point
  double close_depth = 3.0;        // metres; "close" points count for the keyframe decision
  int min_inliers = 15;            // fewer pose inliers => tracking lost
  // A frame tracked from the frame before may not imply a faster camera than this (metres per
  // second): a pose that jumps further came from a wrong consensus (e.g. a crowd's features), and
  // the frame counts as lost instead. Hand-held and robot RGB-D cameras stay well below.
  double max_speed_m_s = 3.0;
  // A frame found again after a bridged loss (tracking.predict_through_loss_s) must agree with the
  // bridged pose: its camera centre within 3 cm + a t^2 / 2 of it, t the time since the last
  // tracked frame, a this (metres per second squared). The ground truth of fr1_xyz, fr1_desk and
  // Bonn crowd stays within 10 m/s^2 frame to frame; a camera that jumps by more followed walkers
  // whose features the masks missed (unchecked while lost). 0 = off.
  double max_acceleration_m_s2 = 10.0;
  int max_frames_between_keyframes = 30;   // at most one second without a keyframe (at 30 Hz)
  int min_frames_between_keyframes = 0;
  double keyframe_tracked_ratio = 0.75;    // new keyframe when tracked/ref-keyframe points < this
  // Pose-change criterion (relative pose between the frame and its reference keyframe).
  double keyframe_translation = 0.10;      // metres
  double keyframe_rotation_deg = 10.0;     // degrees
  // A camera that has moved less than this since the last keyframe is still: it gets no new
  // keyframe while tracking holds (people walking through a still view only add their own
  // points and occlusions, which the other criteria would answer with a keyframe per frame).
  double keyframe_still_translation = 0.02;  // metres
  double keyframe_still_rotation_deg = 2.0;  // degrees
  int local_map_keyframes = 40;            // co-visible keyframes in the local map
  // Also try the still-camera prediction beside the constant-velocity one and keep the better
  // supported. Meant for crowds walking past a camera that stops (the velocity prediction can lock
  // onto them); off by default: on Bonn crowd it helped (ATE 0.55 -> 0.23-0.38 m) but not to the
  // target, and on fr1_desk one deterministic run went from 0.016 to 0.019 m.
  bool still_camera_hypothesis = false;
  // Re-read keypoint depths where the depth camera saw them when the depth image is not taken at
  // the RGB image's time (map::compensateDepthDelay), using the constant-velocity motion.
  bool compensate_depth_delay = true;
  // When tracking fails (people covering the view, a covered lens), frames up to this long after
  // the last tracked one get the constant-velocity prediction as their pose (report: "predicted"),
  // and the motion model keeps looking where that prediction says; 0 = off.
  double predict_through_loss_s = 0.3;
  // While lost (after the prediction above, and when relocalisation found nothing), each frame is
  // also searched against the local map around the last tracked pose, with the full inlier bar:
  // people walking past a camera that keeps looking at the same place leave too few features for
  // the BoW search, but a projection search still finds the static ones.
  bool search_last_pose_when_lost = true;
  // A view with at least crowded_view_share of its features in the dynamic mask (close walkers)
  // gets at most one keyframe per crowded_keyframe_spacing frames: its pose can drift with
  // walkers' unmasked limbs, and a keyframe per frame maps them and anchors the drift (Bonn
  // crowd, t = 18.8-19.5 s: a keyframe at every frame, poses 0.3-0.4 m off). 0 = no limit.
  double crowded_view_share = 0.5;
  int crowded_keyframe_spacing = 5;

  static constexpr const char* kSection = "tracking";
  template <class V> void fields(V& v) {
    v("min_depth", min_depth); v("max_depth", max_depth); v("close_depth", close_depth);
    v("min_inliers", min_inliers); v("max_speed_m_s", max_speed_m_s);
    v("max_acceleration_m_s2", max_acceleration_m_s2);
    v("max_frames_between_keyframes", max_frames_between_keyframes);
    v("min_frames_between_keyframes", min_frames_between_keyframes);
    v("keyframe_tracked_ratio", keyframe_tracked_ratio);
    v("keyframe_translation", keyframe_translation); v("keyframe_rotation_deg", keyframe_rotation_deg);
    v("keyframe_still_translation", keyframe_still_translation);
    v("keyframe_still_rotation_deg", keyframe_still_rotation_deg);
    v("local_map_keyframes", local_map_keyframes);
    v("still_camera_hypothesis", still_camera_hypothesis); v("compensate_depth_delay", compensate_depth_delay);
    v("predict_through_loss_s", predict_through_loss_s); v("crowded_view_share", crowded_view_share);
    v("search_last_pose_when_lost", search_last_pose_when_lost);
    v("crowded_keyframe_spacing", crowded_keyframe_spacing);
  }
  void validate() const;
};

// ORB matching by projection and descriptor (matching/matcher.hpp) in tracking, local mapping and
// loop closing. Depth agreement is judged in pixels of virtual disparity, with the camera's bf().
struct MatcherOptions {
  int max_distance = 100;     // Hamming distance accepted for a match
  int strict_distance = 50;   // for matches without geometric guidance
  double ratio = 0.8;         // best / second-best (different features) must be below this
  bool check_orientation = true;

  static constexpr const char* kSection = "matching";
  template <class V> void fields(V& v) {
    v("max_distance", max_distance); v("strict_distance", strict_distance); v("ratio", ratio);
    v("check_orientation", check_orientation);
  }
  void validate() const;
};

struct MappingOptions {
  int covisible_for_triangulation = 10;  // neighbours searched for new points
  int local_ba_iterations = 10;
  bool local_ba = true;
  double redundant_keyframe_ratio = 0.9;  // culled when this share of its points is seen by >= 3 others
  // After the last frame: one bundle adjustment over every keyframe and point, so the saved
  // trajectory does not depend on how far local mapping kept up during the run.
  bool final_global_ba = true;
  int global_ba_iterations = 20;

  static constexpr const char* kSection = "mapping";
  template <class V> void fields(V& v) {
    v("covisible_for_triangulation", covisible_for_triangulation);
    v("local_ba_iterations", local_ba_iterations); v("local_ba", local_ba);
    v("redundant_keyframe_ratio", redundant_keyframe_ratio);
    v("final_global_ba", final_global_ba); v("global_ba_iterations", global_ba_iterations);
  }
  void validate() const;
};

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
  // this many more extracted outside it (duplicates skipped). 0 = off.
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
    v("stage2_keyframes", stage2_keyframes); v("stage1_min_interval_s", stage1_min_interval_s);
    v("stage1_max_reprojection_px", stage1_max_reprojection_px);
    v("min_features_outside_mask", min_features_outside_mask);
    v("free_space_outside_mask", free_space_outside_mask); v("mask_hold_previous", mask_hold_previous);
  }
  void validate() const;
};

struct SemanticOptions {
  SegmenterKind segmenter = SegmenterKind::kDeepLab;
  // Inference backend of the deeplab segmenter: xnnpack (XNNPACK: the same model file and
  // masks as OpenCV dnn, 4.7-6.4x faster on one thread, so real-time masks are fresher; needs
  // libxnnpack-dev at build time) | opencv (OpenCV dnn, the reference).
  SegmentationBackend backend = SegmentationBackend::kXnnpack;
  // Empty: looked for in $DESSLAM_SHARED_DIR/models, ../shared/models, <exe>/../../shared/models
  // (semantic::resolveModelPath) as deeplabv3_mnv2_voc_257.onnx.
  std::string model_path;
  // Checked before the model is loaded; empty skips the check (for a model of your own).
  std::string model_sha256 = "affb6c7119ea36f686f718f887f719db19091fb43014e16402148764c2a0d05d";
  std::string mask_dir;               // for segmenter = mask_dir: one PNG per RGB frame
  std::vector<int> dynamic_classes{15};  // PASCAL VOC ids (15 = person)
  // Threads for the network. backend = opencv: cv::setNumThreads() is process-wide, so the
  // application applies this; the semantic library never calls it. backend = xnnpack: the
  // segmenter's own thread pool (1 = on the semantic thread itself, no pool).
  int threads = 1;
  // Real-time mode (--realtime): the network starts at most this often (0 = as often as it can).
  // On 2 cores an unthrottled network takes a whole core and starves mapping; masks between are
  // carried forward along optical flow.
  double realtime_max_rate_hz = 10.0;
  // A keyframe made while the mask was carried forward (real time, emulated latency) gets its own
  // frame's mask before local mapping uses it (segmented for it when the stream skipped that
  // frame): the features in it leave the keyframe, and the points only it held leave the map.
  bool keyframe_exact_mask = true;
  // While tracking is lost (or no map has started), a frame waits for its own mask instead of
  // taking a carried one (real time: segmented at once, ahead of the stream). A grown, misplaced
  // mask leaves too few static features to relocalise or start a map, and a frame without a pose
  // loses nothing by being a few milliseconds later.
  bool own_mask_when_lost = true;

  static constexpr const char* kSection = "semantic";
  template <class V> void fields(V& v) {
    v("segmenter", segmenter); v("backend", backend); v("model_path", model_path); v("model_sha256", model_sha256);
    v("mask_dir", mask_dir); v("dynamic_classes", dynamic_classes); v("threads", threads);
    v("realtime_max_rate_hz", realtime_max_rate_hz); v("keyframe_exact_mask", keyframe_exact_mask);
    v("own_mask_when_lost", own_mask_when_lost);
  }
  void validate() const;
};

struct DenseOptions {
  bool enabled = true;
  double voxel_size = 0.01;      // metres
  double min_depth = 0.1;        // metres
  double max_depth = 4.0;        // metres
  int pixel_stride = 2;          // back-project every n-th pixel in u and v
  int outlier_neighbors = 20;    // statistical outlier removal
  double outlier_std_ratio = 2.0;
  double octomap_resolution = 0.05;  // metres
  // The exclude (dynamic) mask is grown by this radius before back-projection: depth at a
  // person's silhouette bleeds into the background, and those pixels would leave ghosts.
  int exclude_dilation_px = 3;
  // Pixels whose depth differs from a 4-neighbour by more than this share of their depth are
  // dropped ("flying pixels" at depth discontinuities); 0 keeps them.
  double depth_edge_ratio = 0.05;
  int queue_capacity = 16;           // keyframes waiting for the dense mapping thread
  int render_width = 1024;           // PNG preview of the map (pixels)
  int render_height = 768;
  // Exported voxels must have been seen by at least this many keyframes (1 = all voxels).
  int min_observations = 1;
  // Free-space carving: each new keyframe's depth is compared with the voxels already in the map;
  // a voxel it sees THROUGH (every reading in a 3x3 window more than carve_tolerance beyond it)
  // gets a miss, and voxels with at least as many misses as observations are left out of the export. The
  // ghost of a person who walked on is seen through by the keyframes that follow; a static
  // surface is not (depth checks and masks miss parts of people: dark clothes, limbs).
  // Part of the dynamic-scene handling: `dynamic.mode: off` (the plain core) turns it off too.
  bool carve_free_space = true;
  double carve_tolerance = 0.05;  // metres

  static constexpr const char* kSection = "dense";
  template <class V> void fields(V& v) {
    v("enabled", enabled); v("voxel_size", voxel_size); v("min_depth", min_depth);
    v("max_depth", max_depth); v("pixel_stride", pixel_stride);
    v("outlier_neighbors", outlier_neighbors); v("outlier_std_ratio", outlier_std_ratio);
    v("octomap_resolution", octomap_resolution); v("exclude_dilation_px", exclude_dilation_px);
    v("depth_edge_ratio", depth_edge_ratio); v("queue_capacity", queue_capacity);
    v("render_width", render_width); v("render_height", render_height);
    v("min_observations", min_observations); v("carve_free_space", carve_free_space);
    v("carve_tolerance", carve_tolerance);
  }
  void validate() const;
};

// Relocalisation when tracking is lost (tracking/relocaliser.hpp): bag-of-words candidates from
// the keyframe database, descriptor matching within vocabulary nodes, PnP-RANSAC, pose-only
// optimisation, guided search by projection.
struct RelocalisationOptions {
  bool enabled = true;
  // Bag-of-words vocabulary file; empty: vocab/desslam_orb_k10l5.bin of the project, looked for
  // by place::resolveVocabularyPath (beside the working directory or the program).
  std::string vocabulary;
  int direct_index_level = 2;        // vocabulary tree level (root = 0) grouping features for matching
  int max_candidates = 10;           // best-scoring keyframes (or covisibility groups) tried
  bool group_covisible = true;       // rank candidates by the score of their covisibility group
  double group_score_ratio = 0.75;   // groups scoring below this share of the best are left out
  int max_descriptor_distance = 50;  // Hamming distance accepted for a descriptor match
  double match_ratio = 0.75;         // best / second-best distance must be below this
  int min_matches = 15;              // descriptor matches a candidate needs before PnP
  int ransac_iterations = 300;
  double ransac_reprojection_px = 4.0;  // inlier threshold of PnP-RANSAC (undistorted pixels)
  double ransac_confidence = 0.99;
  int min_pnp_inliers = 15;          // PnP-RANSAC inliers needed to go on
  int min_inliers = 50;              // pose-optimisation inliers (after guided search) to accept
  double search_radius_px = 10.0;    // guided search window around projected covisible points

  static constexpr const char* kSection = "relocalisation";
  template <class V> void fields(V& v) {
    v("enabled", enabled); v("vocabulary", vocabulary); v("direct_index_level", direct_index_level);
    v("max_candidates", max_candidates); v("group_covisible", group_covisible);
    v("group_score_ratio", group_score_ratio); v("max_descriptor_distance", max_descriptor_distance);
    v("match_ratio", match_ratio); v("min_matches", min_matches); v("ransac_iterations", ransac_iterations);
    v("ransac_reprojection_px", ransac_reprojection_px); v("ransac_confidence", ransac_confidence);
    v("min_pnp_inliers", min_pnp_inliers); v("min_inliers", min_inliers); v("search_radius_px", search_radius_px);
  }
  void validate() const;
};

// Loop closing (loop/loop_closer.hpp): place recognition over the keyframe BoW database, a rigid
// SE(3) from 3-D-3-D matches (depth makes scale observable), pose-graph optimisation over the
// essential graph, then a global bundle adjustment in its own thread.
struct LoopOptions {
  bool enabled = true;
  int min_keyframes_between_loops = 10;  // after a closed loop (and at the map's start) no detection
  int min_consistent_keyframes = 3;      // a candidate group must recur in this many consecutive keyframes
  int group_size = 10;                   // a candidate's covisibility group: it and its best neighbours
  double group_score_ratio = 0.75;       // groups below this share of the best group's score are dropped
  int max_candidates = 3;                // consistent candidates verified geometrically per keyframe
  // A loop found from the keyframe must also hold from its best covisible keyframes: of its
  // confirm_keyframes best covisibles (all it has, if fewer), every one must see at least
  // min_confirm_matches of the loop's points where the loop's transform puts them (descriptor
  // and 3-D agreement). A keyframe without covisibles cannot close a loop. 0: no confirmation.
  int confirm_keyframes = 2;
  int min_confirm_matches = 20;
  int max_descriptor_distance = 50;      // Hamming; BoW-guided matching has no geometry, so strict
  double match_ratio = 0.75;             // best / second-best descriptor distance
  int ransac_iterations = 300;
  // 3-D inlier distance at 1 m depth; grows with depth^2 like Kinect-type depth noise.
  double ransac_threshold_m = 0.02;
  int min_rigid_inliers = 20;            // RANSAC inliers to accept a candidate
  double projection_radius_px = 10.0;    // guided search of the loop group's points (level 0 pixels)
  int min_loop_matches = 40;             // matches after the guided search to close the loop
  int strong_covisibility_weight = 100;  // covisibility edges in the essential graph
  int pose_graph_iterations = 20;
  bool global_ba = true;                 // global BA in its own thread after each closed loop
  int global_ba_iterations = 10;
  int queue_capacity = 64;               // keyframes waiting; when full the oldest is dropped

  static constexpr const char* kSection = "loop";
  template <class V> void fields(V& v) {
    v("enabled", enabled); v("min_keyframes_between_loops", min_keyframes_between_loops);
    v("min_consistent_keyframes", min_consistent_keyframes); v("group_size", group_size);
    v("group_score_ratio", group_score_ratio); v("max_candidates", max_candidates);
    v("confirm_keyframes", confirm_keyframes);
    v("min_confirm_matches", min_confirm_matches);
    v("max_descriptor_distance", max_descriptor_distance); v("match_ratio", match_ratio);
    v("ransac_iterations", ransac_iterations); v("ransac_threshold_m", ransac_threshold_m);
    v("min_rigid_inliers", min_rigid_inliers); v("projection_radius_px", projection_radius_px);
    v("min_loop_matches", min_loop_matches); v("strong_covisibility_weight", strong_covisibility_weight);
    v("pose_graph_iterations", pose_graph_iterations); v("global_ba", global_ba);
    v("global_ba_iterations", global_ba_iterations); v("queue_capacity", queue_capacity);
  }
  void validate() const;
};

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
  // A map lost before it has this many keyframes gets no relocalisation time: a new one starts at
  // once (a young map has too little to relocalise against).
  int young_map_keyframes = 5;
  // A keyframe recognised in another map must recur over this many consecutive keyframes before
  // the maps are merged (loop.min_consistent_keyframes applies to loops within a map).
  int merge_min_consistent_keyframes = 2;
  // A merge's first, BoW-guided matching pairs the keyframe's features with the map points of the
  // candidate and its best covisibles, this many keyframes in all (1: the candidate alone): a map
  // started in a crowd is often seen again only 20-30 degrees apart, by keyframes holding 100-300
  // map points, too few alone. Loops within a map match the candidate alone: there a missed loop
  // costs some drift, while a wider match let walkers moving as one body fit false loops (Bonn).
  int merge_match_keyframes = 5;

  static constexpr const char* kSection = "atlas";
  template <class V> void fields(V& v) {
    v("enabled", enabled); v("min_initial_features", min_initial_features);
    v("min_initial_cells", min_initial_cells); v("new_map_after_lost_s", new_map_after_lost_s);
    v("young_map_keyframes", young_map_keyframes);
    v("merge_min_consistent_keyframes", merge_min_consistent_keyframes);
    v("merge_match_keyframes", merge_match_keyframes);
  }
  void validate() const;
};

// Plausibility of the depth scale over the first frames of a run (plausibility/depth_scale.hpp):
// the camera's motion measured through the depth images (PnP on depth-backed ORB features) is
// compared with the same motion in metres from the sequence's ground truth; a depth factor that
// makes them disagree by max_scale_error or more is an error (`run --force`: a warning).
struct PlausibilityOptions {
  bool enabled = true;
  double window_s = 1.0;       // the first second of frames is looked at ...
  double max_window_s = 3.0;   // ... or longer (up to this) while the camera has moved too little
  // A frame pair counts when the camera moved this far (ground truth). The reference's own error
  // (a motion-capture body offset from the optical centre, clock offsets: millimetres to a
  // centimetre) is divided by the baseline: Bonn crowd measured 1.23x at 3-8 cm, 0.96x at 11-20 cm.
  double min_baseline_m = 0.10;
  int max_pairs = 8;           // frame pairs measured (spread over the window)
  int min_pairs = 3;           // fewer measured pairs: the scale is not judged
  // Per-pair ratios may spread (median absolute deviation / median) up to this; more: not judged.
  double max_spread = 0.25;
  double max_scale_error = 1.5;   // measured ratio above this or below 1/this: an error
  double warn_scale_error = 1.15; // ... above this (below 1/this): a warning
  // Depth range of an indoor RGB-D camera: the median valid reading of the first frames outside
  // it is an error whether or not there is ground truth.
  double min_median_depth_m = 0.1;
  double max_median_depth_m = 20.0;

  static constexpr const char* kSection = "plausibility";
  template <class V> void fields(V& v) {
    v("enabled", enabled); v("window_s", window_s); v("max_window_s", max_window_s);
    v("min_baseline_m", min_baseline_m); v("max_pairs", max_pairs); v("min_pairs", min_pairs);
    v("max_spread", max_spread); v("max_scale_error", max_scale_error); v("warn_scale_error", warn_scale_error);
    v("min_median_depth_m", min_median_depth_m); v("max_median_depth_m", max_median_depth_m);
  }
  void validate() const;
};

// ROS 1 bag input (`desslam run <file.bag>`, src/bag): the topics read. A section of the config
// rather than run flags because the topics belong to the recording set-up, like the camera preset
// beside them, and so land in report.json's settings with everything else. Defaults: TUM RGB-D's.
struct BagOptions {
  std::string rgb_topic = "/camera/rgb/image_color";          // sensor_msgs/Image rgb8 or bgr8
  std::string depth_topic = "/camera/depth/image";            // sensor_msgs/Image 32FC1 m or 16UC1 mm
  std::string camera_info_topic = "/camera/rgb/camera_info";  // sensor_msgs/CameraInfo (intrinsics)

  static constexpr const char* kSection = "bag";
  template <class V> void fields(V& v) {
    v("rgb_topic", rgb_topic); v("depth_topic", depth_topic); v("camera_info_topic", camera_info_topic);
  }
  void validate() const;
};

// Everything a run is configured with (one YAML file, one section per struct).
struct SystemOptions {
  CameraOptions camera;
  OrbOptions orb;
  TrackingOptions tracking;
  MatcherOptions matching;
  MappingOptions mapping;
  DynamicOptions dynamic;
  SemanticOptions semantic;
  DenseOptions dense;
  LoopOptions loop;
  RelocalisationOptions relocalisation;
  AtlasOptions atlas;
  PlausibilityOptions plausibility;
  BagOptions bag;

  template <class F> void sections(F&& f) {
    f(camera); f(orb); f(tracking); f(matching); f(mapping); f(dynamic); f(semantic); f(dense); f(loop); f(relocalisation); f(atlas);
    f(plausibility); f(bag);
  }
  void validate() const;
};

}  // namespace desslam
