#include "dense/dense_map.hpp"

#include <open3d/geometry/PointCloud.h>

namespace desslam::dense {

std::array<uint8_t, 3> semanticColour(uint8_t label) {
  std::array<uint8_t, 3> rgb{0, 0, 0};
  int id = label;
  for (int shift = 7; shift >= 0 && id > 0; --shift, id >>= 3) {
    rgb[0] |= static_cast<uint8_t>(((id >> 0) & 1) << shift);
    rgb[1] |= static_cast<uint8_t>(((id >> 1) & 1) << shift);
    rgb[2] |= static_cast<uint8_t>(((id >> 2) & 1) << shift);
  }
  return rgb;
}

DenseMap::DenseMap(const DenseOptions& options, const PinholeCamera& camera)
    : options_(options), back_projector_(std::make_shared<const BackProjector>(options, camera)) {}

void DenseMap::addKeyframe(const DenseKeyframe& keyframe) {
  auto cloud = std::make_shared<const KeyframeCloud>(voxelDownsample((*back_projector_)(keyframe), options_.voxel_size));
  addCloud(std::move(cloud), keyframe.T_w_c);
}

void DenseMap::addCloud(std::shared_ptr<const KeyframeCloud> cloud, const SE3& T_w_c) {
  const uint64_t id = cloud->keyframe_id;
  entries_[id] = Entry{std::move(cloud), T_w_c};
}

void DenseMap::removeKeyframe(uint64_t keyframe_id) { entries_.erase(keyframe_id); }

void DenseMap::updatePoses(const PoseMap& T_w_c_by_id) {
  for (const auto& [id, pose] : T_w_c_by_id) {
    if (auto it = entries_.find(id); it != entries_.end()) it->second.T_w_c = pose;
  }
}

const SE3& DenseMap::poseOf(uint64_t id, const Entry& entry, const PoseMap& T_w_c_by_id) const {
  const auto it = T_w_c_by_id.find(id);
  return it != T_w_c_by_id.end() ? it->second : entry.T_w_c;
}

size_t DenseMap::storedPointCount() const {
  size_t n = 0;
  for (const auto& [id, entry] : entries_) n += entry.cloud->size();
  return n;
}

PoseMap DenseMap::poses() const {
  PoseMap out;
  for (const auto& [id, entry] : entries_) out.emplace(id, entry.T_w_c);
  return out;
}

std::shared_ptr<open3d::geometry::PointCloud> DenseMap::fuse(bool semantic_colour) const {
  return fuse(PoseMap{}, semantic_colour);
}

std::shared_ptr<open3d::geometry::PointCloud> DenseMap::fuse(const PoseMap& T_w_c_by_id,
                                                             bool semantic_colour) const {
  auto merged = std::make_shared<open3d::geometry::PointCloud>();
  merged->points_.reserve(storedPointCount());
  merged->colors_.reserve(storedPointCount());
  for (const auto& [id, entry] : entries_) {
    const SE3& T_w_c = poseOf(id, entry, T_w_c_by_id);
    const Mat3 R = T_w_c.rotation();
    const Vec3& t = T_w_c.translation();
    const KeyframeCloud& cloud = *entry.cloud;
    for (size_t i = 0; i < cloud.size(); ++i) {
      merged->points_.push_back(R * cloud.points_c[i].cast<double>() + t);
      std::array<uint8_t, 3> rgb = cloud.rgb[i];
      if (semantic_colour) {
        if (cloud.labels[i] != 0) {
          rgb = semanticColour(cloud.labels[i]);
        } else {  // background keeps its structure, in grey, so classes stand out
          const auto grey = static_cast<uint8_t>((rgb[0] * 30 + rgb[1] * 59 + rgb[2] * 11) / 100);
          rgb = {grey, grey, grey};
        }
      }
      merged->colors_.emplace_back(rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
    }
  }
  if (merged->points_.empty()) return merged;
  auto fused = merged->VoxelDownSample(options_.voxel_size);
  if (options_.outlier_neighbors > 0 && fused->points_.size() > static_cast<size_t>(options_.outlier_neighbors)) {
    fused = std::get<0>(fused->RemoveStatisticalOutliers(static_cast<size_t>(options_.outlier_neighbors),
                                                         options_.outlier_std_ratio));
  }
  return fused;
}

std::vector<WorldScan> DenseMap::worldScans(const PoseMap& T_w_c_by_id) const {
  std::vector<WorldScan> scans;
  scans.reserve(entries_.size());
  for (const auto& [id, entry] : entries_) {
    const SE3& T_w_c = poseOf(id, entry, T_w_c_by_id);
    const Mat3 R = T_w_c.rotation();
    const Vec3& t = T_w_c.translation();
    WorldScan scan;
    scan.keyframe_id = id;
    scan.timestamp = entry.cloud->timestamp;
    scan.origin_w = t;
    scan.points_w.reserve(entry.cloud->size());
    for (const Eigen::Vector3f& p : entry.cloud->points_c) scan.points_w.push_back(R * p.cast<double>() + t);
    scans.push_back(std::move(scan));
  }
  return scans;
}

}  // namespace desslam::dense
