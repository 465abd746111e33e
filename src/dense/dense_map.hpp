// The dense map: a world voxel hash whose voxels remember WHERE they are in the camera frame of
// the keyframe that created them (their anchor), so the map follows bundle adjustment and loop
// closure without keeping any keyframe's cloud.
//
// Why this shape: keeping one cloud per keyframe (the first design) costs memory in proportion
// to the number of keyframes (10-14 M points on Bonn crowd); re-integrating images needs the
// images. Here each voxel stores ~40 bytes once, however many keyframes see it, and only a pose
// per keyframe (~100 bytes) grows with the keyframe count.
//  - addKeyframe(): the keyframe's points go to world with its current pose, are grouped by
//    world voxel (one observation per voxel and keyframe), and merged into the existing voxel
//    (expressed in the anchor's frame with the anchor's current pose: running means of point and
//    colour, Boyer-Moore vote for the label) or create a voxel anchored at this keyframe.
//  - updatePoses(): new poses for any keyframe ever added, culled ones included. Voxel keys
//    were computed with the anchors' poses at the last re-key; when some anchor has moved so
//    that one of its points may have moved more than half a voxel (|dt| + angle * range), the
//    voxels of the moved anchors are re-keyed, and voxels that now share a key are merged.
//    The re-key is deferred to the next integrate(), the only user of the keys (extract() and
//    worldScans() place voxels with the poses themselves): pose updates between two keyframes
//    cost one re-key, and an export after the final bundle adjustment none. Only voxels whose
//    key actually changes touch the index.
//  - extract()/exportCloud(): each voxel goes to world with its anchor's newest pose, one voxel
//    downsample merges voxels that moved together (weighted by observations), then the
//    min_observations and statistical outlier filters.
//  - removeKeyframe(): a culled keyframe keeps its voxels (other views are merged into them) and
//    keeps following the poses sent for it (its parent's pose times the stored relative pose).
//
// Not thread-safe by itself; DenseMappingThread (dense_thread.hpp) guards one with a mutex.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "dense/back_projection.hpp"
#include "dense/dense_keyframe.hpp"
#include "dense/dense_options.hpp"
#include "dense/voxel_index.hpp"

namespace open3d::geometry {
class PointCloud;
}

namespace desslam::dense {

using PoseMap = std::map<uint64_t, SE3>;  // keyframe id -> T_w_c

struct DenseMapStats {
  size_t voxels = 0;           // stored voxels
  size_t voxel_misses = 0;     // carve(): voxel-keyframe pairs seen through, summed
  size_t keyframes = 0;        // keyframes ever added (culled included)
  size_t culled = 0;
  size_t rekeys = 0;           // partial re-keyings triggered by pose updates (done, not pending)
  size_t voxels_rekeyed = 0;   // voxels moved to a new key, summed over re-keyings
  size_t voxels_merged = 0;    // voxels merged into another by re-keying
};

class DenseMap {
 public:
  DenseMap(const DenseOptions& options, const PinholeCamera& camera);

  // Back-projects (BackProjector) and integrates the keyframe with keyframe.T_w_c.
  void addKeyframe(const DenseKeyframe& keyframe);
  // Integrates a camera-frame cloud made elsewhere (the mapping thread back-projects outside
  // its lock) with pose T_w_c. A keyframe id seen before is integrated again (a new
  // observation) and its pose replaced.
  // With a depth image (CV_32F metres, the keyframe's raw depth) and dense.carve_free_space, the
  // voxels already stored are first checked against it (carve()).
  void integrate(const KeyframeCloud& cloud, const SE3& T_w_c, const cv::Mat& depth = cv::Mat());
  // Counts a miss for every stored voxel that a camera at T_w_c with this depth image sees
  // through (see DenseOptions::carve_free_space). Returns the number of voxels missed.
  size_t carve(const cv::Mat& depth, const SE3& T_w_c);
  // Culled keyframe: its voxels and pose stay (see the top of this file). Unknown ids ignored.
  void removeKeyframe(uint64_t keyframe_id);
  // New poses of keyframes already added; other ids are ignored. Marks the keys stale when
  // an anchor moved enough; the next integrate() re-keys (see above), or rekeyNow().
  void updatePoses(const PoseMap& T_w_c_by_id);
  // Re-keys now if a pose update left keys stale (integrate() does this itself).
  void rekeyNow();

  // Voxels in the world frame (poses from T_w_c_by_id, else the newest stored), merged by one
  // voxel downsample at voxel_size, then min_observations; NO outlier removal. Ordered by world
  // voxel key, so the result does not depend on insertion order of equal keys.
  DenseCloud extract(const PoseMap& T_w_c_by_id = {}) const;
  // extract() + statistical outlier removal (removeStatisticalOutliers below).
  DenseCloud exportCloud(const PoseMap& T_w_c_by_id = {}) const;
  // exportCloud() as an Open3D cloud (toOpen3d below).
  std::shared_ptr<open3d::geometry::PointCloud> fuse(const PoseMap& T_w_c_by_id, bool semantic_colour = false) const;
  std::shared_ptr<open3d::geometry::PointCloud> fuse(bool semantic_colour = false) const;

  // Stored voxels grouped by anchor keyframe (ordered by id): world points with the anchor's
  // pose (chosen as in extract()), origin = the anchor's camera centre, timestamp = the
  // anchor's (= first-seen time of its voxels). For OctoMap ray insertion and map checks.
  std::vector<WorldScan> worldScans(const PoseMap& T_w_c_by_id = {}) const;

  bool contains(uint64_t keyframe_id) const { return keyframe_index_.count(keyframe_id) != 0; }
  bool isCulled(uint64_t keyframe_id) const;
  size_t keyframeCount() const { return keyframes_.size(); }  // ever added, culled included
  size_t voxelCount() const { return voxels_.size(); }  // stored; a pending re-key may merge some
  DenseMapStats stats() const;
  PoseMap poses() const;  // newest stored pose of every keyframe ever added
  const BackProjector& backProjector() const { return *back_projector_; }
  const DenseOptions& options() const { return options_; }

 private:
  struct KeyframeRecord {
    uint64_t id = 0;
    Timestamp timestamp = 0;
    SE3 T_w_c;        // newest pose
    SE3 T_w_c_keyed;  // pose the anchored voxels' keys were computed with
    float max_range = 0;     // farthest anchored point from the camera (bounds motion by rotation)
    // Holds every anchored voxel's p_anchor (grown on every write, never shrunk): carve() skips
    // the voxels of anchors whose box lies outside the view.
    Eigen::AlignedBox3f box_anchor;
    uint32_t anchored = 0;   // voxels anchored here
    bool culled = false;
  };
  struct Voxel {
    uint64_t key = 0;
    Eigen::Vector3f p_anchor = Eigen::Vector3f::Zero();  // running mean, anchor's camera frame
    uint32_t anchor = 0;        // index into keyframes_
    uint32_t observations = 0;  // keyframes merged in
    uint32_t misses = 0;        // later keyframes that saw through it (carve())
    std::array<uint8_t, 3> rgb{0, 0, 0};
    uint8_t label = 0;        // Boyer-Moore candidate
    uint8_t label_votes = 0;  // its vote margin
  };

  uint32_t registerKeyframe(uint64_t id, Timestamp timestamp, const SE3& T_w_c);
  void setAnchorPoint(Voxel& voxel, const Eigen::Vector3f& p_anchor);  // keeps box_anchor whole
  uint64_t keyOf(const Vec3& p_w) const;
  Vec3 worldPoint(const Voxel& voxel, const std::vector<SE3>& T_w_anchor) const;
  // Merges voxel `from` into `into` (both stored voxels, world poses as given).
  void mergeVoxel(Voxel& into, const Voxel& from, const std::vector<SE3>& T_w_anchor);
  void rekeyMovedAnchors();
  std::vector<SE3> anchorPoses(const PoseMap& T_w_c_by_id) const;

  DenseOptions options_;
  PinholeCamera camera_;
  std::shared_ptr<const BackProjector> back_projector_;
  std::vector<KeyframeRecord> keyframes_;
  std::unordered_map<uint64_t, uint32_t> keyframe_index_;  // id -> index into keyframes_
  std::vector<Voxel> voxels_;
  VoxelIndex voxel_index_;  // key -> index into voxels_
  bool keys_stale_ = false;  // some anchor moved more than half a voxel since its voxels were keyed
  size_t rekeys_ = 0, voxels_rekeyed_ = 0, voxels_merged_ = 0, voxel_misses_ = 0;
};

// Statistical outlier removal on the exported cloud (Open3D's, with DenseOptions'
// outlier_neighbors / outlier_std_ratio; nothing happens when outlier_neighbors is 0 or the
// cloud has no more points than that).
void removeStatisticalOutliers(DenseCloud& cloud, const DenseOptions& options);

// Open3D cloud with colours: the image's RGB, or with semantic_colour the PASCAL VOC palette
// of each point's label (unlabelled points grey).
std::shared_ptr<open3d::geometry::PointCloud> toOpen3d(const DenseCloud& cloud, bool semantic_colour = false);

// PASCAL VOC colour map (bit-interleaved label id), as segmentation viewers draw classes.
std::array<uint8_t, 3> semanticColour(uint8_t label);

}  // namespace desslam::dense
