// Is camera.depth_factor right for this sequence? Checked on a few frames of the first second,
// before the run (apps/cmd_run.cpp).
//
// Why ground truth: the depth scale cannot be seen in the images. A scene k times larger, seen
// from a path k times longer, gives exactly the same RGB images and the same depth image up to
// the factor k; every relation between image motion and depth (parallax f * t / z, triangulated
// against measured depth, essential-matrix geometry) is unchanged, because it only involves the
// ratio t / z. A wrong depth_factor therefore makes a perfectly consistent, k-times-scaled
// reconstruction; RGB-D tracking works, only in the wrong unit. A depth-independent measurement
// of the scale needs something known in metres: here the ground-truth trajectory that TUM, Bonn
// and the synthetic sequences come with (groundtruth.txt, motion capture in metres).
//
// The method: frame pairs (the first frame and up to plausibility.max_pairs later ones whose
// ground-truth camera centres lie at least plausibility.min_baseline_m apart). For each pair, ORB
// features of the first frame with a depth reading become 3-D points (in the depth image's unit),
// matched by descriptor to the second frame's features, and PnP-RANSAC gives the relative pose
// in depth-image units; the ratio of its translation to the ground-truth translation (ground
// truth taken at the depth image's time for the first frame and at the RGB time for the second)
// is how many times too large the depth readings are. The median over the pairs is the estimate,
// its median absolute deviation the spread. The depth-independent two-view geometry (essential
// matrix of the same matches) gives the translation direction, which is compared with PnP's as a
// cross-check of the matches: it cannot see the scale either, but a pair whose two directions
// disagree (plausibility.max_direction_disagreement_deg) holds two motions, e.g. walkers filling
// the view, and is left out. (The ground truth's direction cannot serve: Bonn's is a marker body's,
// in axes turned 150-160 degrees from the camera's.)
//
// Without ground truth only the depth range is judged (median valid reading within
// plausibility.min/max_median_depth_m), which catches gross errors only: fr1_xyz read with
// depth_factor 1000 has a median of ~6 m, plausible for a room.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/camera_options.hpp"
#include "core/se3.hpp"
#include "core/trajectory.hpp"
#include "core/types.hpp"
#include "plausibility/plausibility_options.hpp"

namespace desslam::plausibility {

// A frame of the check: the images and, when there is ground truth, the camera's pose (metres)
// at the RGB image's and at the depth image's time.
struct CheckFrame {
  Timestamp timestamp = 0;  // RGB time
  cv::Mat gray;             // CV_8UC1, raw (distorted) image
  cv::Mat depth;            // CV_32F metres (raw / depth_factor), registered to the raw RGB image
  std::optional<SE3> T_w_c_rgb;    // reference pose at the RGB time
  std::optional<SE3> T_w_c_depth;  // reference pose at the depth image's time
};

struct DepthStatistics {
  int frames = 0;
  double valid_share = 0;  // pixels with a reading (> 0), over all frames
  double median_m = 0;     // of the valid readings (every other pixel)
  double p05_m = 0, p95_m = 0;
};

struct PairMeasurement {
  double t_first = 0, t_second = 0;
  int matches = 0;      // descriptor matches with depth in the first frame
  int inliers = 0;      // PnP-RANSAC inliers
  double reference_m = 0;  // ground-truth distance between the camera centres
  double depth_units = 0;  // the same distance from PnP, in the depth image's unit
  double ratio = 0;        // depth_units / reference_m
  // PnP vs essential-matrix translation direction (-1: no essential matrix). Both come from the
  // pair's matches, and a wrong depth factor scales the PnP motion without turning it: a large
  // angle means the two estimators found different motions in the matches (people walking
  // through), and the pair is left out (plausibility.max_direction_disagreement_deg).
  double direction_angle_deg = -1;
};

struct ScaleEstimate {
  bool judged = false;
  double ratio = 1;   // median of the pairs' ratios: depth readings are this many times too large
  double spread = 0;  // median |ratio_i - ratio| / ratio
  std::vector<PairMeasurement> pairs;  // the pairs counted
  int pairs_tried = 0;
  int pairs_disagreeing = 0;  // measured, but left out: direction_angle_deg above the limit
  std::string not_judged;  // why not, when !judged
};

struct Finding {
  bool error = false;  // false: a warning
  std::string key;     // the option at fault, e.g. camera.depth_factor
  std::string message;
};

struct CheckResult {
  DepthStatistics depth;
  ScaleEstimate scale;
  std::vector<Finding> findings;
  bool hasError() const;
  // The first error's message (empty when none).
  std::string firstError() const;
  nlohmann::json toJson() const;
};

// Which frames of a sequence to look at (indices into `timestamps`): the first frame with a
// reference pose, then up to options.max_pairs later frames within options.window_s (extended up
// to options.max_window_s while fewer have moved options.min_baseline_m), evenly spread. Without
// reference poses: up to max_pairs + 1 frames evenly over window_s (depth range only).
// `reference` may be empty or one optional pose per timestamp.
std::vector<size_t> selectFrames(const std::vector<Timestamp>& timestamps,
                                 const std::vector<std::optional<SE3>>& reference,
                                 const PlausibilityOptions& options);

// Runs the checks on frames (as selected above; frames[0] is the first of every pair).
CheckResult checkDepthScale(const std::vector<CheckFrame>& frames, const CameraOptions& camera,
                            const PlausibilityOptions& options);

// Depth statistics alone (every other pixel of every frame).
DepthStatistics depthStatistics(const std::vector<cv::Mat>& depths);

// The pose at time t, interpolated between the two trajectory poses around it (at most
// max_gap_s apart; the trajectory sorted by time); nullopt outside or across a larger gap.
std::optional<SE3> interpolatePose(const Trajectory& trajectory, Timestamp t, double max_gap_s = 0.1);

// A depth factor to suggest for a measured ratio: factor * ratio, rounded to a common one (1000,
// 5000, 10000) within 10 %, else to two significant digits.
double suggestedDepthFactor(double depth_factor, double ratio);

}  // namespace desslam::plausibility
