// Dense alignment of one depth image to another: projective point-to-plane ICP, coarse to fine,
// on the pixels that neither image's dynamic mask covers. Tracking asks it when no feature gives
// a pose (tracking.depth_odometry_max_s): people covering most of the texture, or motion blur,
// still leave walls, floor and furniture in the depth image. Needs no features and no map.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/se3.hpp"

namespace desslam::tracking {

struct DepthAlignmentOptions {
  double min_depth_m = 0.1;  // readings outside [min, max] are not used
  double max_depth_m = 4.0;
  // Pyramid levels used, coarse to fine: level l has 2^l x 2^l pixels per cell (1: 320 x 240 for a
  // 640 x 480 image). Iterations per level, coarsest first.
  int finest_level = 1;
  std::vector<int> iterations{10, 8, 6};  // levels finest_level + 2, + 1, finest_level
  // A pair whose points lie further apart than this at the finest level (twice as far per coarser
  // level) is no correspondence: another surface, or something that moved.
  double max_point_distance_m = 0.04;
  double max_normal_angle_deg = 30.0;
  double huber_m = 0.01;  // point-to-plane residuals beyond weigh less (depth noise, missed people)

  // Acceptance, at the finest level after the last iteration:
  int min_correspondences = 3000;      // pairs (a 320 x 240 level has 76800 pixels)
  double min_overlap = 0.4;            // pairs / the aligned image's usable pixels
  double max_rms_m = 0.015;            // point-to-plane RMS of the pairs
  // Smallest eigenvalue of the pairs' mean normal-equation matrix, rotation scaled by the mean
  // depth (units of the translation part): 0 where one plane (a wall) leaves a motion unseen,
  // about 0.017 for a room's corner with floor and furniture (the weakest motion a turn about the
  // optical axis). Views of a desk and a wall on fr1 composites gave 0.005-0.013 and drifted 1.5-5 cm
  // per frame; a corner seen at a grazing angle, 0.007-0.011, slid 12 cm without the prior.
  double min_constraint = 0.015;

  void validate() const;  // throws ConfigError naming the field ("depth_alignment.<field>")
};

struct DepthAlignmentResult {
  SE3 T_cur_ref;              // the estimate (the guess when nothing could be aligned)
  int correspondences = 0;    // at the finest level, last iteration
  double overlap = 0;         // correspondences / usable pixels of the aligned image at that level
  double rms_m = 0;           // point-to-plane RMS of the correspondences
  double constraint = 0;      // see DepthAlignmentOptions::min_constraint
  bool accepted = false;      // every acceptance bound met
  const char* refusal = "";   // the first bound missed (for the debug log); empty when accepted
};

// One depth image prepared for alignment (DepthAligner::prepare): per pyramid level, camera-frame
// points (z = 0: none) and normals. Pixels the mask covers (non-zero) or without a reading in
// range have no point.
struct DepthPyramid {
  struct Level {
    int width = 0, height = 0, scale = 1;
    std::vector<Vec3> points;
    std::vector<Vec3> normals;  // zero where a point has no usable neighbours
    int usable = 0;             // pixels with a point and a normal
  };
  std::vector<Level> levels;  // index = level; those below DepthAlignmentOptions::finest_level empty
};

class DepthAligner {
 public:
  DepthAligner(const PinholeCamera& camera, const DepthAlignmentOptions& options);  // validates options
  // depth: CV_32F metres (raw, distorted pixels as the sensor gives them); mask: CV_8U of the same
  // size or empty. No levels when depth is empty or not CV_32F.
  DepthPyramid prepare(const cv::Mat& depth, const cv::Mat& mask) const;
  // Aligns `cur` to `ref` from the guess T_cur_ref (the camera motion from ref to cur).
  DepthAlignmentResult align(const DepthPyramid& ref, const DepthPyramid& cur, const SE3& T_cur_ref_guess) const;

 private:
  PinholeCamera camera_;
  DepthAlignmentOptions options_;
  std::vector<std::vector<Vec2>> rays_;  // per level, per cell: the undistorted pixel of its centre
};

}  // namespace desslam::tracking
