// Synthetic RGB-D scenes with exact ground truth: a textured room with furniture boxes and an
// optional person-sized box walking back and forth, rendered by per-pixel ray casting.
//
// World frame: z up, floor at z = 0; the room spans x in [-sx/2, sx/2], y in [-sy/2, sy/2],
// z in [0, sz] for room_size = (sx, sy, sz). Furniture boxes stand on the floor against the walls
// (0.3-0.7 m deep), leaving the middle free for the camera paths of sim/camera_path.hpp.
// Every surface carries its own seeded random texture (multi-scale, high-contrast shapes) so an
// ORB extractor finds plenty of distinctive corners.
#pragma once

#include <filesystem>
#include <memory>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera_options.hpp"
#include "core/option_fields.hpp"
#include "core/se3.hpp"
#include "core/trajectory.hpp"
#include "sim/camera_path.hpp"

namespace desslam::sim {

struct SceneOptions {
  Vec3 room_size{6.0, 4.0, 3.0};  // metres (x, y, z), see the world frame above
  int static_boxes = 6;           // furniture boxes against the walls (depth variation)
  bool moving_object = false;     // a textured person-sized box moving through the view
  Vec3 moving_size{0.5, 0.5, 1.7};       // metres (x, y, z)
  // Bottom-centre of the moving box at time moving_t0, and its velocity. It moves in a straight
  // line and bounces back at the edge of the free middle (0.7 m from the walls), so it stays in
  // the room at any time and never walks through furniture. With the default paths the defaults keep it in view for the first ~7 s, about
  // 1-1.8 m from the camera, covering 20-35 % of the image.
  Vec3 moving_start{-0.8, 1.0, 0.0};     // metres
  Vec3 moving_velocity{0.5, 0.0, 0.0};   // metres / second
  double moving_t0 = 1000.0;             // seconds; the paths' default t0
  double depth_noise_sigma = 0.0;        // metres at 1 m depth, growing with z^2 like Kinect noise
  double texture_px_per_m = 256.0;       // texture resolution on surfaces
  unsigned seed = 7;                     // textures, box layout and depth noise

  void validate() const;  // throws ConfigError naming the bad field ("sim.<field>")
};

struct RenderedFrame {
  cv::Mat bgr;           // CV_8UC3
  cv::Mat depth;         // CV_32F metres (z along the optical axis), 0 = no reading
  cv::Mat dynamic_mask;  // CV_8U, 255 where the moving object is seen
};

class SyntheticScene {
 public:
  SyntheticScene(const SceneOptions& scene, const CameraOptions& camera);

  // Ray casts every pixel (with the camera's distortion, if any). Deterministic: the same pose
  // and time give identical images; depth noise depends on (seed, time, pixel).
  // Throws InputError when the camera centre is outside the room.
  RenderedFrame render(const SE3& T_w_c, double time_s) const;

  // Ground truth for tests: distance from a world point to the nearest static surface (walls,
  // floor, ceiling, furniture boxes).
  double distanceToStaticSurface(const Vec3& p_w) const;
  // Whether a world point lies on/in the moving object at time t (within tolerance, metres).
  // Always false when the scene has no moving object.
  bool onMovingObject(const Vec3& p_w, double time_s, double tolerance = 0.01) const;
  // The moving object's axis-aligned box at time t (empty box when there is none).
  Eigen::AlignedBox3d movingObjectBox(double time_s) const;

  const SceneOptions& options() const;
  const CameraOptions& camera() const;

 private:
  struct Impl;
  std::shared_ptr<const Impl> impl_;  // immutable after construction: copies share it
};

// Depth timestamps in writeSequence are the RGB timestamps plus this (exercises pairing).
inline constexpr double kDepthTimeOffset = 0.005;

// Writes a TUM-layout sequence into dir (created if needed): rgb/<t>.png, depth/<t>.png (16-bit,
// value = metres * camera.depth_factor), rgb.txt, depth.txt, groundtruth.txt (TUM trajectory,
// timestamps with 6 decimals) and, when write_masks, masks/<same name as rgb> (255 = moving).
// Frame i shows the scene at path[i].timestamp; its depth file is stamped kDepthTimeOffset later.
// Throws InputError when dir cannot be written.
void writeSequence(const std::filesystem::path& dir, const SyntheticScene& scene, const Trajectory& path,
                   const CameraOptions& camera, bool write_masks);

// 640x480, fx = fy = 525, cx = 319.5, cy = 239.5, no distortion, depth factor 5000, 30 fps.
CameraOptions syntheticCamera();
// The same camera at half the image size (pixel centres kept: c' = (c + 0.5) / 2 - 0.5), for
// tests and benchmarks that fuse many frames.
CameraOptions halfResolution(CameraOptions camera);

}  // namespace desslam::sim
