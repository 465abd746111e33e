// The dense map: per-keyframe clouds kept in the camera frame, fused into one world cloud with
// whatever poses are newest (after bundle adjustment or loop closure) when asked.
//
// Not thread-safe by itself; DenseMappingThread (dense_thread.hpp) guards one with a mutex.
// Copies are cheap (clouds are shared, immutable), which is how that thread snapshots it.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include "core/camera.hpp"
#include "core/options.hpp"
#include "core/se3.hpp"
#include "dense/back_projection.hpp"
#include "dense/dense_keyframe.hpp"

namespace open3d::geometry {
class PointCloud;
}

namespace desslam::dense {

using PoseMap = std::map<uint64_t, SE3>;  // keyframe id -> T_w_c

class DenseMap {
 public:
  DenseMap(const DenseOptions& options, const PinholeCamera& camera);

  // Back-projects (BackProjector), voxel-downsamples at voxel_size and stores the keyframe
  // with its pose. A keyframe id already present is replaced.
  void addKeyframe(const DenseKeyframe& keyframe);
  // Stores a cloud made elsewhere (the mapping thread back-projects outside its lock).
  void addCloud(std::shared_ptr<const KeyframeCloud> cloud, const SE3& T_w_c);
  // Culled keyframes; unknown ids are ignored.
  void removeKeyframe(uint64_t keyframe_id);
  // Replaces stored poses of the given ids; ids not in the map are ignored.
  void updatePoses(const PoseMap& T_w_c_by_id);

  // World-frame fused cloud: each keyframe cloud transformed by R_wc p + t_wc with the pose
  // from T_w_c_by_id (keyframes missing there use their stored pose), concatenated, voxel
  // downsampled at voxel_size, then statistical outlier removal (outlier_neighbors,
  // outlier_std_ratio; skipped when outlier_neighbors is 0). Colours are the image's RGB, or
  // with semantic_colour the PASCAL VOC palette of each point's label (unlabelled points grey).
  std::shared_ptr<open3d::geometry::PointCloud> fuse(const PoseMap& T_w_c_by_id,
                                                     bool semantic_colour = false) const;
  std::shared_ptr<open3d::geometry::PointCloud> fuse(bool semantic_colour = false) const;

  // Per-keyframe world clouds and camera centres (poses chosen as in fuse()), ordered by id.
  std::vector<WorldScan> worldScans(const PoseMap& T_w_c_by_id = {}) const;

  bool contains(uint64_t keyframe_id) const { return entries_.count(keyframe_id) != 0; }
  size_t keyframeCount() const { return entries_.size(); }
  size_t storedPointCount() const;  // sum over keyframe clouds (after per-keyframe downsampling)
  PoseMap poses() const;            // stored poses
  const BackProjector& backProjector() const { return *back_projector_; }
  const DenseOptions& options() const { return options_; }

 private:
  struct Entry {
    std::shared_ptr<const KeyframeCloud> cloud;
    SE3 T_w_c;
  };
  const SE3& poseOf(uint64_t id, const Entry& entry, const PoseMap& T_w_c_by_id) const;

  DenseOptions options_;
  std::shared_ptr<const BackProjector> back_projector_;
  std::map<uint64_t, Entry> entries_;
};

// PASCAL VOC colour map (bit-interleaved label id), as segmentation viewers draw classes.
std::array<uint8_t, 3> semanticColour(uint8_t label);

}  // namespace desslam::dense
