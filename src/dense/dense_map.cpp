#include "dense/dense_map.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <open3d/geometry/PointCloud.h>

namespace desslam::dense {

namespace {

// 21 bits per axis (offset binary): +-2^20 voxels, +-10 km at 1 cm.
constexpr int64_t kKeyOffset = int64_t{1} << 20;
constexpr uint64_t kKeyMask = (uint64_t{1} << 21) - 1;

uint64_t packKey(int64_t x, int64_t y, int64_t z) {
  return (static_cast<uint64_t>(x + kKeyOffset) & kKeyMask) | ((static_cast<uint64_t>(y + kKeyOffset) & kKeyMask) << 21) |
         ((static_cast<uint64_t>(z + kKeyOffset) & kKeyMask) << 42);
}

// A rigid transform as a matrix: millions of points are moved, quaternion rotation is slower.
struct Rigid {
  Mat3 R;
  Vec3 t;
  explicit Rigid(const SE3& T) : R(T.rotation()), t(T.translation()) {}
  Vec3 operator*(const Vec3& p) const { return R * p + t; }
};

// Boyer-Moore majority vote state, mergeable: (candidate, margin).
void vote(uint8_t& candidate, uint8_t& margin, uint8_t label, unsigned weight) {
  if (label == candidate) {
    margin = static_cast<uint8_t>(std::min(255u, margin + weight));
  } else if (margin >= weight) {
    margin = static_cast<uint8_t>(margin - weight);
  } else {
    candidate = label;
    margin = static_cast<uint8_t>(std::min(255u, weight - margin));
  }
}

uint8_t toByte(double v) { return static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L)); }

}  // namespace

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

void DenseCloud::keepOnly(const std::vector<size_t>& indices) {
  auto pick = [&](auto& values) {
    std::remove_reference_t<decltype(values)> kept;
    kept.reserve(indices.size());
    for (size_t i : indices) kept.push_back(values[i]);
    values = std::move(kept);
  };
  pick(points_w);
  pick(rgb);
  pick(labels);
  pick(first_seen);
  pick(observations);
}

DenseMap::DenseMap(const DenseOptions& options, const PinholeCamera& camera)
    : options_(options), camera_(camera), back_projector_(std::make_shared<const BackProjector>(options, camera)) {}

uint64_t DenseMap::keyOf(const Vec3& p_w) const {
  const double inv = 1.0 / options_.voxel_size;
  return packKey(static_cast<int64_t>(std::floor(p_w.x() * inv)), static_cast<int64_t>(std::floor(p_w.y() * inv)),
                 static_cast<int64_t>(std::floor(p_w.z() * inv)));
}

uint32_t DenseMap::registerKeyframe(uint64_t id, Timestamp timestamp, const SE3& T_w_c) {
  if (const auto it = keyframe_index_.find(id); it != keyframe_index_.end()) {
    // Seen before: a new observation with a new pose; the anchored voxels must be re-keyed
    // with that pose first, so treat it as a pose update.
    updatePoses({{id, T_w_c}});
    return it->second;
  }
  const auto index = static_cast<uint32_t>(keyframes_.size());
  KeyframeRecord record;
  record.id = id;
  record.timestamp = timestamp;
  record.T_w_c = T_w_c;
  record.T_w_c_keyed = T_w_c;
  keyframes_.push_back(record);
  keyframe_index_.emplace(id, index);
  return index;
}

void DenseMap::addKeyframe(const DenseKeyframe& keyframe) {
  integrate((*back_projector_)(keyframe), keyframe.T_w_c, keyframe.depth);
}

void DenseMap::setAnchorPoint(Voxel& voxel, const Eigen::Vector3f& p_anchor) {
  voxel.p_anchor = p_anchor;
  keyframes_[voxel.anchor].box_anchor.extend(p_anchor);
}

namespace {
// Whether some point of the box (anchor frame) may lie in the view volume of a camera at
// T_c_a: min_z <= z <= max_z and the projection inside [min_x, max_x) x [min_y, max_y). False
// only when all 8 corners lie outside one bounding plane of that volume (it is convex), so no
// voxel inside could pass carve()'s per-voxel test. Planes are widened by a margin against
// rounding.
bool mayBeInView(const Eigen::AlignedBox3f& box, const Eigen::Matrix3f& R_c_a, const Eigen::Vector3f& t_c_a,
                 const PinholeCamera& camera, float min_z, float max_z) {
  if (box.isEmpty()) return false;
  constexpr float kMarginPx = 2.0f, kMarginM = 0.01f;
  // u >= min_x  <=>  x - z (min_x - cx) / fx >= 0 (for z > 0), and so on.
  const float left = static_cast<float>((camera.minX() - kMarginPx - camera.cx()) / camera.fx());
  const float right = static_cast<float>((camera.maxX() + kMarginPx - camera.cx()) / camera.fx());
  const float top = static_cast<float>((camera.minY() - kMarginPx - camera.cy()) / camera.fy());
  const float bottom = static_cast<float>((camera.maxY() + kMarginPx - camera.cy()) / camera.fy());
  bool all_near = true, all_far = true, all_left = true, all_right = true, all_top = true, all_bottom = true;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3f p = R_c_a * box.corner(static_cast<Eigen::AlignedBox3f::CornerType>(c)) + t_c_a;
    all_near = all_near && p.z() < min_z - kMarginM;
    all_far = all_far && p.z() > max_z + kMarginM;
    all_left = all_left && p.x() < left * p.z();
    all_right = all_right && p.x() > right * p.z();
    all_top = all_top && p.y() < top * p.z();
    all_bottom = all_bottom && p.y() > bottom * p.z();
  }
  return !(all_near || all_far || all_left || all_right || all_top || all_bottom);
}
}  // namespace

size_t DenseMap::carve(const cv::Mat& depth, const SE3& T_w_c) {
  if (depth.empty() || voxels_.empty()) return 0;
  const float tolerance = static_cast<float>(options_.carve_tolerance);
  const float min_z = static_cast<float>(options_.min_depth), max_z = static_cast<float>(options_.max_depth);
  // Per anchor: camera-from-anchor, so each voxel costs one small matrix product, and whether
  // any of its voxels can be in view at all (most anchors of a long run are not).
  std::vector<Eigen::Matrix3f> R_c_a(keyframes_.size());
  std::vector<Eigen::Vector3f> t_c_a(keyframes_.size());
  std::vector<uint8_t> in_view(keyframes_.size());
  const SE3 T_c_w = T_w_c.inverse();
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    const SE3 T_c_a = T_c_w * keyframes_[k].T_w_c;
    R_c_a[k] = T_c_a.rotation().cast<float>();
    t_c_a[k] = T_c_a.translation().cast<float>();
    in_view[k] = mayBeInView(keyframes_[k].box_anchor, R_c_a[k], t_c_a[k], camera_, min_z, max_z) ? 1 : 0;
  }
  size_t missed = 0;
  for (Voxel& voxel : voxels_) {
    if (!in_view[voxel.anchor]) continue;
    const Eigen::Vector3f p_c = R_c_a[voxel.anchor] * voxel.p_anchor + t_c_a[voxel.anchor];
    if (p_c.z() < min_z || p_c.z() > max_z) continue;
    const Vec2 uv = camera_.project(p_c.cast<double>());
    if (!camera_.inImage(uv)) continue;
    const Vec2 raw = camera_.hasDistortion() ? camera_.distort(uv) : uv;  // depth is registered to the raw image
    const int x = static_cast<int>(std::lround(raw.x())), y = static_cast<int>(std::lround(raw.y()));
    if (x < 1 || y < 1 || x >= depth.cols - 1 || y >= depth.rows - 1) continue;
    // Seen through only if every reading around the pixel lies beyond: a voxel on a silhouette,
    // a pixel off after projection, would otherwise "see" the background beside it.
    bool through = depth.at<float>(y, x) > 0;
    for (int dy = -1; dy <= 1 && through; ++dy)
      for (int dx = -1; dx <= 1 && through; ++dx) {
        const float d = depth.at<float>(y + dy, x + dx);
        if (d > 0 && d <= p_c.z() + tolerance) through = false;
      }
    if (through) {
      ++voxel.misses;
      ++missed;
    }
  }
  voxel_misses_ += missed;
  return missed;
}

void DenseMap::integrate(const KeyframeCloud& cloud, const SE3& T_w_c, const cv::Mat& depth) {
  if (options_.carve_free_space) carve(depth, T_w_c);
  const uint32_t self = registerKeyframe(cloud.keyframe_id, cloud.timestamp, T_w_c);
  rekeyNow();  // the merge below looks voxels up by key
  const Rigid to_world(T_w_c);

  // 1. This keyframe's points grouped by world voxel: one observation per voxel and keyframe.
  struct Group {
    Vec3 sum_w = Vec3::Zero();
    Vec3 sum_rgb = Vec3::Zero();
    uint32_t count = 0;
    uint8_t label = 0, label_votes = 0;
  };
  VoxelIndex group_of;  // key -> index into groups
  group_of.reserve(cloud.size());
  std::vector<Group> groups;
  std::vector<uint64_t> group_keys;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Vec3 p_w = to_world * cloud.points_c[i].cast<double>();
    const uint64_t key = keyOf(p_w);
    const auto [group, inserted] = group_of.tryEmplace(key, static_cast<uint32_t>(groups.size()));
    if (inserted) {
      groups.emplace_back();
      group_keys.push_back(key);
    }
    Group& g = groups[*group];
    g.sum_w += p_w;
    g.sum_rgb += Vec3(cloud.rgb[i][0], cloud.rgb[i][1], cloud.rgb[i][2]);
    ++g.count;
    vote(g.label, g.label_votes, cloud.labels.empty() ? 0 : cloud.labels[i], 1);
  }

  // 2. Merge into existing voxels (in their anchor's frame, anchor's current pose) or create.
  const Rigid to_camera(T_w_c.inverse());
  std::vector<Rigid> to_anchor;  // anchor index -> T_a_w (a few hundred: cheaper than on demand)
  to_anchor.reserve(keyframes_.size());
  for (const KeyframeRecord& r : keyframes_) to_anchor.emplace_back(r.T_w_c.inverse());
  voxel_index_.reserve(voxel_index_.size() + groups.size());
  KeyframeRecord& record = keyframes_[self];
  for (size_t g = 0; g < groups.size(); ++g) {
    const Group& group = groups[g];
    const Vec3 mean_w = group.sum_w / group.count;
    const Vec3 mean_rgb = group.sum_rgb / group.count;
    const auto [stored, inserted] = voxel_index_.tryEmplace(group_keys[g], static_cast<uint32_t>(voxels_.size()));
    if (inserted) {
      Voxel voxel;
      voxel.key = group_keys[g];
      const Vec3 p_c = to_camera * mean_w;
      voxel.anchor = self;
      setAnchorPoint(voxel, p_c.cast<float>());
      voxel.observations = 1;
      voxel.rgb = {toByte(mean_rgb.x()), toByte(mean_rgb.y()), toByte(mean_rgb.z())};
      voxel.label = group.label;
      voxel.label_votes = 1;
      voxels_.push_back(voxel);
      record.max_range = std::max(record.max_range, static_cast<float>(p_c.norm()));
      ++record.anchored;
      continue;
    }
    Voxel& voxel = voxels_[*stored];
    const Vec3 p_a = to_anchor[voxel.anchor] * mean_w;
    const double w = 1.0 / (voxel.observations + 1.0);
    setAnchorPoint(voxel, (voxel.p_anchor.cast<double>() * (1 - w) + p_a * w).cast<float>());
    for (int c = 0; c < 3; ++c) voxel.rgb[c] = toByte(voxel.rgb[c] * (1 - w) + mean_rgb[c] * w);
    vote(voxel.label, voxel.label_votes, group.label, 1);
    ++voxel.observations;
  }
}

void DenseMap::removeKeyframe(uint64_t keyframe_id) {
  if (const auto it = keyframe_index_.find(keyframe_id); it != keyframe_index_.end())
    keyframes_[it->second].culled = true;
}

bool DenseMap::isCulled(uint64_t keyframe_id) const {
  const auto it = keyframe_index_.find(keyframe_id);
  return it != keyframe_index_.end() && keyframes_[it->second].culled;
}

void DenseMap::updatePoses(const PoseMap& T_w_c_by_id) {
  for (const auto& [id, pose] : T_w_c_by_id) {
    const auto it = keyframe_index_.find(id);
    if (it == keyframe_index_.end()) continue;
    KeyframeRecord& record = keyframes_[it->second];
    record.T_w_c = pose;
    if (record.anchored == 0) {
      record.T_w_c_keyed = pose;
      continue;
    }
    // Farthest any anchored point may have moved: |dt| + angle * range.
    const SE3 delta = pose * record.T_w_c_keyed.inverse();
    const double moved = (pose.translation() - record.T_w_c_keyed.translation()).norm() +
                         delta.rotationAngle() * record.max_range;
    keys_stale_ = keys_stale_ || moved > 0.5 * options_.voxel_size;
  }
}

void DenseMap::rekeyNow() {
  if (!keys_stale_) return;
  rekeyMovedAnchors();
  keys_stale_ = false;
}

std::vector<SE3> DenseMap::anchorPoses(const PoseMap& T_w_c_by_id) const {
  std::vector<SE3> poses;
  poses.reserve(keyframes_.size());
  for (const KeyframeRecord& record : keyframes_) {
    const auto it = T_w_c_by_id.find(record.id);
    poses.push_back(it != T_w_c_by_id.end() ? it->second : record.T_w_c);
  }
  return poses;
}

Vec3 DenseMap::worldPoint(const Voxel& voxel, const std::vector<SE3>& T_w_anchor) const {
  return T_w_anchor[voxel.anchor] * voxel.p_anchor.cast<double>();
}

void DenseMap::mergeVoxel(Voxel& into, const Voxel& from, const std::vector<SE3>& T_w_anchor) {
  const Vec3 p_into = T_w_anchor[into.anchor].inverse() * worldPoint(from, T_w_anchor);
  const double total = static_cast<double>(into.observations) + from.observations;
  const double w = from.observations / total;
  setAnchorPoint(into, (into.p_anchor.cast<double>() * (1 - w) + p_into * w).cast<float>());
  for (int c = 0; c < 3; ++c) into.rgb[c] = toByte(into.rgb[c] * (1 - w) + from.rgb[c] * w);
  vote(into.label, into.label_votes, from.label, from.label_votes);
  into.observations += from.observations;
  into.misses += from.misses;
}

void DenseMap::rekeyMovedAnchors() {
  // Which anchors moved enough to matter (same bound as in updatePoses()).
  std::vector<uint8_t> moved(keyframes_.size(), 0);
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    const KeyframeRecord& r = keyframes_[k];
    const SE3 delta = r.T_w_c * r.T_w_c_keyed.inverse();
    const double bound = (r.T_w_c.translation() - r.T_w_c_keyed.translation()).norm() + delta.rotationAngle() * r.max_range;
    moved[k] = r.anchored > 0 && bound > 0.5 * options_.voxel_size ? 1 : 0;
  }
  const std::vector<SE3> poses = anchorPoses({});
  std::vector<Rigid> to_world;
  to_world.reserve(poses.size());
  for (const SE3& T : poses) to_world.emplace_back(T);

  // Take the voxels whose key changed out of the index, then put them back under their new
  // keys; a voxel landing on an occupied key is merged into the one with the older anchor
  // (first seen). Most voxels of a moved anchor keep their key (a correction of a few mm):
  // those stay in the index untouched.
  std::vector<std::pair<uint32_t, uint64_t>> moving;  // voxel index, new key
  for (uint32_t i = 0; i < voxels_.size(); ++i) {
    const Voxel& voxel = voxels_[i];
    if (!moved[voxel.anchor]) continue;
    const uint64_t key = keyOf(to_world[voxel.anchor] * voxel.p_anchor.cast<double>());
    if (key == voxel.key) continue;
    moving.emplace_back(i, key);
    if (const uint32_t* it = voxel_index_.find(voxel.key); it != nullptr && *it == i) voxel_index_.erase(voxel.key);
  }
  std::vector<uint32_t> dead;
  for (const auto& [i, key] : moving) {
    Voxel& voxel = voxels_[i];
    voxel.key = key;
    const auto [stored, inserted] = voxel_index_.tryEmplace(voxel.key, i);
    if (inserted) continue;
    Voxel& other = voxels_[*stored];
    if (keyframes_[voxel.anchor].timestamp < keyframes_[other.anchor].timestamp) {
      mergeVoxel(voxel, other, poses);
      dead.push_back(*stored);
      *stored = i;
    } else {
      mergeVoxel(other, voxel, poses);
      dead.push_back(i);
    }
  }
  // Remove merged voxels: swap with the last one, highest index first so the last is alive.
  std::sort(dead.begin(), dead.end(), std::greater<>());
  for (uint32_t i : dead) {
    --keyframes_[voxels_[i].anchor].anchored;
    const auto last = static_cast<uint32_t>(voxels_.size() - 1);
    if (i != last) {
      voxels_[i] = voxels_[last];
      *voxel_index_.find(voxels_[i].key) = i;
    }
    voxels_.pop_back();
  }
  for (size_t k = 0; k < keyframes_.size(); ++k)
    if (moved[k]) keyframes_[k].T_w_c_keyed = keyframes_[k].T_w_c;
  ++rekeys_;
  voxels_rekeyed_ += moving.size();
  voxels_merged_ += dead.size();
}

DenseCloud DenseMap::extract(const PoseMap& T_w_c_by_id) const {
  const std::vector<SE3> poses = anchorPoses(T_w_c_by_id);
  std::vector<Rigid> to_world;
  to_world.reserve(poses.size());
  for (const SE3& T : poses) to_world.emplace_back(T);

  struct Merged {
    uint64_t key;
    Vec3 sum_w = Vec3::Zero();
    Vec3 sum_rgb = Vec3::Zero();
    uint32_t observations = 0;
    uint32_t misses = 0;
    Timestamp first_seen = 0;
    uint8_t label = 0, label_votes = 0;
  };
  std::vector<Merged> merged;
  merged.reserve(voxels_.size());
  VoxelIndex index;  // world key -> index into merged
  index.reserve(voxels_.size());
  for (const Voxel& voxel : voxels_) {
    const Vec3 p_w = to_world[voxel.anchor] * voxel.p_anchor.cast<double>();
    const uint64_t key = keyOf(p_w);
    const auto [slot, inserted] = index.tryEmplace(key, static_cast<uint32_t>(merged.size()));
    if (inserted) {
      merged.push_back(Merged{key});
      merged.back().first_seen = keyframes_[voxel.anchor].timestamp;
    }
    Merged& m = merged[*slot];
    m.sum_w += p_w * voxel.observations;
    m.sum_rgb += Vec3(voxel.rgb[0], voxel.rgb[1], voxel.rgb[2]) * voxel.observations;
    m.observations += voxel.observations;
    m.misses += voxel.misses;
    m.first_seen = std::min(m.first_seen, keyframes_[voxel.anchor].timestamp);
    vote(m.label, m.label_votes, voxel.label, std::max<unsigned>(1, voxel.label_votes));
  }
  std::sort(merged.begin(), merged.end(), [](const Merged& a, const Merged& b) { return a.key < b.key; });

  DenseCloud out;
  for (const Merged& m : merged) {
    if (m.observations < static_cast<uint32_t>(options_.min_observations)) continue;
    if (options_.carve_free_space && m.misses >= m.observations) continue;  // seen through as often as seen
    out.points_w.push_back(m.sum_w / m.observations);
    const Vec3 rgb = m.sum_rgb / m.observations;
    out.rgb.push_back({toByte(rgb.x()), toByte(rgb.y()), toByte(rgb.z())});
    out.labels.push_back(m.label);
    out.first_seen.push_back(m.first_seen);
    out.observations.push_back(m.observations);
  }
  return out;
}

void removeStatisticalOutliers(DenseCloud& cloud, const DenseOptions& options) {
  if (options.outlier_neighbors <= 0 || cloud.size() <= static_cast<size_t>(options.outlier_neighbors)) return;
  open3d::geometry::PointCloud points;
  points.points_ = cloud.points_w;
  const auto [filtered, kept] =
      points.RemoveStatisticalOutliers(static_cast<size_t>(options.outlier_neighbors), options.outlier_std_ratio);
  std::vector<size_t> indices = kept;
  std::sort(indices.begin(), indices.end());
  cloud.keepOnly(indices);
}

DenseCloud DenseMap::exportCloud(const PoseMap& T_w_c_by_id) const {
  DenseCloud cloud = extract(T_w_c_by_id);
  removeStatisticalOutliers(cloud, options_);
  return cloud;
}

std::shared_ptr<open3d::geometry::PointCloud> toOpen3d(const DenseCloud& cloud, bool semantic_colour) {
  auto out = std::make_shared<open3d::geometry::PointCloud>();
  out->points_ = cloud.points_w;
  out->colors_.reserve(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    std::array<uint8_t, 3> rgb = cloud.rgb[i];
    if (semantic_colour) {
      if (cloud.labels[i] != 0) {
        rgb = semanticColour(cloud.labels[i]);
      } else {  // background keeps its structure, in grey, so classes stand out
        const auto grey = static_cast<uint8_t>((rgb[0] * 30 + rgb[1] * 59 + rgb[2] * 11) / 100);
        rgb = {grey, grey, grey};
      }
    }
    out->colors_.emplace_back(rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
  }
  return out;
}

std::shared_ptr<open3d::geometry::PointCloud> DenseMap::fuse(bool semantic_colour) const {
  return fuse(PoseMap{}, semantic_colour);
}

std::shared_ptr<open3d::geometry::PointCloud> DenseMap::fuse(const PoseMap& T_w_c_by_id, bool semantic_colour) const {
  return toOpen3d(exportCloud(T_w_c_by_id), semantic_colour);
}

std::vector<WorldScan> DenseMap::worldScans(const PoseMap& T_w_c_by_id) const {
  const std::vector<SE3> poses = anchorPoses(T_w_c_by_id);
  std::vector<WorldScan> scans(keyframes_.size());
  for (size_t k = 0; k < keyframes_.size(); ++k) {
    scans[k].keyframe_id = keyframes_[k].id;
    scans[k].timestamp = keyframes_[k].timestamp;
    scans[k].origin_w = poses[k].translation();
    scans[k].points_w.reserve(keyframes_[k].anchored);
  }
  std::vector<Rigid> to_world;
  to_world.reserve(poses.size());
  for (const SE3& T : poses) to_world.emplace_back(T);
  for (const Voxel& voxel : voxels_)
    scans[voxel.anchor].points_w.push_back(to_world[voxel.anchor] * voxel.p_anchor.cast<double>());
  std::erase_if(scans, [](const WorldScan& scan) { return scan.points_w.empty(); });
  std::sort(scans.begin(), scans.end(), [](const WorldScan& a, const WorldScan& b) { return a.keyframe_id < b.keyframe_id; });
  return scans;
}

DenseMapStats DenseMap::stats() const {
  DenseMapStats s;
  s.voxels = voxels_.size();
  s.keyframes = keyframes_.size();
  for (const KeyframeRecord& r : keyframes_) s.culled += r.culled ? 1 : 0;
  s.rekeys = rekeys_;
  s.voxels_rekeyed = voxels_rekeyed_;
  s.voxels_merged = voxels_merged_;
  s.voxel_misses = voxel_misses_;
  return s;
}

PoseMap DenseMap::poses() const {
  PoseMap out;
  for (const KeyframeRecord& r : keyframes_) out.emplace(r.id, r.T_w_c);
  return out;
}

}  // namespace desslam::dense
