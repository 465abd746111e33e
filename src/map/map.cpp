#include "map/map.hpp"

#include <algorithm>
#include <limits>

#include "feature/descriptor.hpp"

namespace desslam::map {

Keyframe* Map::createKeyframe(uint64_t frame_id, Timestamp timestamp, std::string image_name,
                              std::shared_ptr<const FeatureSet> features, std::vector<FeatureStatus> status,
                              cv::Mat half_depth, const SE3& T_c_w, int map_id) {
  const uint64_t id = next_keyframe_id_++;
  auto kf = std::make_unique<Keyframe>(id, frame_id, timestamp, std::move(image_name), std::move(features),
                                       std::move(status), std::move(half_depth), T_c_w);
  Keyframe* raw = kf.get();
  raw->map_id = liveMap(map_id);
  raw->made_in_map = raw->map_id;
  recordOf(raw->map_id);
  raw->map_origin = keyframes_created_per_map_[raw->map_id]++ == 0;
  keyframes_.emplace(id, std::move(kf));
  ++good_keyframes_;
  ++good_keyframes_per_map_[raw->map_id];
  return raw;
}

MapRecord& Map::recordOf(int map_id) {
  auto it = maps_.find(map_id);
  if (it == maps_.end()) {
    MapRecord record;
    record.id = map_id;
    record.reason = "implicit";
    it = maps_.emplace(map_id, record).first;
    next_map_id_ = std::max(next_map_id_, map_id + 1);
  }
  return it->second;
}

int Map::createMap(uint64_t first_frame_id, Timestamp start_time, std::string reason) {
  const int id = next_map_id_++;
  MapRecord& record = recordOf(id);
  record.first_frame_id = first_frame_id;
  record.start_time = start_time;
  record.reason = std::move(reason);
  return id;
}

int Map::liveMap(int map_id) const {
  for (auto it = maps_.find(map_id); it != maps_.end() && it->second.merged_into >= 0;
       it = maps_.find(it->second.merged_into))
    map_id = it->second.merged_into;
  return map_id;
}

size_t Map::keyframeCount(int map_id) const {
  auto it = good_keyframes_per_map_.find(map_id);
  return it == good_keyframes_per_map_.end() ? 0 : it->second;
}

std::vector<MapRecord> Map::mapRecords() const {
  std::vector<MapRecord> out;
  for (const auto& [id, record] : maps_) out.push_back(record);
  return out;
}

void Map::mergeMap(int from, int into, const SE3& T_into_from, Timestamp merged_at) {
  from = liveMap(from);
  into = liveMap(into);
  if (from == into) return;
  const SE3 T_from_into = T_into_from.inverse();
  for (auto& [id, kf] : keyframes_) {
    if (kf->map_id != from) continue;
    kf->T_c_w = kf->T_c_w * T_from_into;  // culled ones follow their parent; keep them consistent too
    kf->map_id = into;
    kf->map_origin = false;
  }
  for (auto& [id, p] : points_) {
    if (p->map_id != from) continue;
    p->position = T_into_from * p->position;
    p->map_id = into;
  }
  good_keyframes_per_map_[into] += good_keyframes_per_map_[from];
  good_keyframes_per_map_[from] = 0;
  MapRecord& record = recordOf(from);
  record.merged_into = into;
  record.T_into_this = T_into_from;
  record.merged_at = merged_at;
}

size_t Map::mergeCount() const {
  return static_cast<size_t>(std::count_if(maps_.begin(), maps_.end(),
                                           [](const auto& entry) { return entry.second.merged_into >= 0; }));
}

MapPoint* Map::createPoint(const Vec3& position, Keyframe* reference) {
  const uint64_t id = next_point_id_++;
  auto point = std::make_unique<MapPoint>(id, position, reference, reference != nullptr ? reference->id : 0);
  MapPoint* raw = point.get();
  if (reference != nullptr) raw->map_id = reference->map_id;
  points_.emplace(id, std::move(point));
  ++good_points_;
  return raw;
}

void Map::setPointBad(MapPoint* point) {
  if (point->bad) return;
  point->bad = true;
  --good_points_;
  for (auto& [kf_id, obs] : point->observations) {
    Keyframe* kf = obs.first;
    if (kf->points[obs.second] == point) kf->points[obs.second] = nullptr;
  }
  point->observations.clear();
}

void Map::setKeyframeBad(Keyframe* kf) {
  if (kf->bad || kf->map_origin) return;  // the first keyframe anchors its map
  for (auto& [id, entry] : kf->connection_weights) {
    Keyframe* other = entry.first;
    other->connection_weights.erase(kf->id);
    auto& oc = other->ordered_connections;
    oc.erase(std::remove(oc.begin(), oc.end(), kf), oc.end());
  }
  for (size_t i = 0; i < kf->points.size(); ++i) {
    if (MapPoint* p = kf->points[i]) {
      kf->points[i] = nullptr;
      eraseObservation(*this, p, kf);
    }
  }
  kf->connection_weights.clear();
  kf->ordered_connections.clear();

  // Re-attach children to the remaining keyframe (its parent or a sibling's tree) they share the
  // most points with; the spanning tree must stay connected for pose propagation.
  Keyframe* parent = kf->parent;
  for (auto& [cid, child] : kf->children) {
    Keyframe* best = parent;
    int best_weight = -1;
    for (auto& [oid, entry] : child->connection_weights) {
      if (entry.first->bad || entry.first == kf) continue;
      if (entry.second > best_weight && entry.first->id < child->id) {
        best_weight = entry.second;
        best = entry.first;
      }
    }
    child->parent = best;
    if (best != nullptr) best->children[child->id] = child;
  }
  kf->children.clear();
  if (parent != nullptr) {
    parent->children.erase(kf->id);
    kf->T_c_parent = kf->T_c_w * parent->T_c_w.inverse();
  }
  kf->bad = true;
  --good_keyframes_;
  --good_keyframes_per_map_[kf->map_id];
}

std::vector<Keyframe*> Map::keyframes() const {
  std::vector<Keyframe*> out;
  out.reserve(good_keyframes_);
  for (const auto& [id, kf] : keyframes_)
    if (!kf->bad) out.push_back(kf.get());
  return out;
}

std::vector<Keyframe*> Map::allKeyframes() const {
  std::vector<Keyframe*> out;
  out.reserve(keyframes_.size());
  for (const auto& [id, kf] : keyframes_) out.push_back(kf.get());
  return out;
}

std::vector<MapPoint*> Map::points() const {
  std::vector<MapPoint*> out;
  out.reserve(good_points_);
  for (const auto& [id, p] : points_)
    if (!p->bad) out.push_back(p.get());
  return out;
}

void addObservation(MapPoint* point, Keyframe* kf, int feature) {
  point->observations[kf->id] = {kf, feature};
  kf->points[feature] = point;
}

void eraseObservation(Map& map, MapPoint* point, Keyframe* kf) {
  auto it = point->observations.find(kf->id);
  if (it == point->observations.end()) return;
  if (kf->points[it->second.second] == point) kf->points[it->second.second] = nullptr;
  point->observations.erase(it);
  if (point->reference == kf && !point->observations.empty()) point->reference = point->observations.begin()->second.first;
  // An RGB-D point is still constrained with one observation, but one left by culling is untrusted.
  if (point->observations.size() < 2) map.setPointBad(point);
}

void replacePoint(Map& map, MapPoint* from, MapPoint* to) {
  if (from == to || from->bad) return;
  for (auto& [kf_id, obs] : from->observations) {
    Keyframe* kf = obs.first;
    if (to->observations.count(kf_id) == 0) {
      kf->points[obs.second] = to;
      to->observations[kf_id] = obs;
    } else {
      kf->points[obs.second] = nullptr;
    }
  }
  from->observations.clear();
  to->visible += from->visible.load();
  to->found += from->found.load();
  from->replaced_by = to;
  map.setPointBad(from);
  updateDescriptor(to);
}

void updateDescriptor(MapPoint* point) {
  std::vector<const uint8_t*> descriptors;
  for (const auto& [kf_id, obs] : point->observations)
    descriptors.push_back(obs.first->features->descriptor(obs.second));
  if (descriptors.empty()) return;
  const size_t n = descriptors.size();
  std::vector<int> distances(n * n, 0);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      distances[i * n + j] = distances[j * n + i] = feature::descriptorDistance(descriptors[i], descriptors[j]);
  size_t best = 0;
  int best_median = std::numeric_limits<int>::max();
  std::vector<int> row(n);
  for (size_t i = 0; i < n; ++i) {
    std::copy(distances.begin() + i * n, distances.begin() + (i + 1) * n, row.begin());
    std::nth_element(row.begin(), row.begin() + (n - 1) / 2, row.end());
    if (row[(n - 1) / 2] < best_median) {
      best_median = row[(n - 1) / 2];
      best = i;
    }
  }
  point->descriptor = cv::Mat(1, 32, CV_8U, const_cast<uint8_t*>(descriptors[best])).clone();
}

void updateNormalAndDepth(MapPoint* point) {
  if (point->observations.empty() || point->reference == nullptr) return;
  Vec3 normal = Vec3::Zero();
  for (const auto& [kf_id, obs] : point->observations) normal += (point->position - obs.first->center()).normalized();
  point->normal = normal.normalized();
  const Keyframe* ref = point->reference;
  auto it = point->observations.find(ref->id);
  if (it == point->observations.end()) return;
  const double distance = (point->position - ref->center()).norm();
  const auto& pyramid = *ref->features->pyramid;
  const int level = ref->features->level(it->second.second);
  // Matchable from the finest to the coarsest pyramid level relative to where it was seen.
  point->max_distance = distance * pyramid.scale[level];
  point->min_distance = point->max_distance / pyramid.scale.back();
}

void updateConnections(Keyframe* kf, int min_weight) {
  std::map<uint64_t, std::pair<Keyframe*, int>> counts;
  for (MapPoint* p : kf->points) {
    if (p == nullptr || p->bad) continue;
    for (const auto& [other_id, obs] : p->observations) {
      if (other_id == kf->id) continue;
      auto& entry = counts[other_id];
      entry.first = obs.first;
      ++entry.second;
    }
  }
  if (counts.empty()) return;

  std::vector<std::pair<int, Keyframe*>> kept;
  Keyframe* best = nullptr;
  int best_weight = 0;
  for (auto& [other_id, entry] : counts) {
    if (entry.second > best_weight) {
      best_weight = entry.second;
      best = entry.first;
    }
    if (entry.second >= min_weight) kept.emplace_back(entry.second, entry.first);
  }
  if (kept.empty()) kept.emplace_back(best_weight, best);

  // Old edges of kf are dropped on both sides, then the new ones added.
  for (auto& [other_id, entry] : kf->connection_weights) {
    Keyframe* other = entry.first;
    other->connection_weights.erase(kf->id);
    auto& oc = other->ordered_connections;
    oc.erase(std::remove(oc.begin(), oc.end(), kf), oc.end());
  }
  kf->connection_weights.clear();
  auto byWeightThenId = [](const Keyframe* owner) {
    return [owner](Keyframe* a, Keyframe* b) {
      const int wa = owner->connection_weights.at(a->id).second;
      const int wb = owner->connection_weights.at(b->id).second;
      return wa != wb ? wa > wb : a->id < b->id;
    };
  };
  for (auto& [weight, other] : kept) {
    kf->connection_weights[other->id] = {other, weight};
    other->connection_weights[kf->id] = {kf, weight};
    auto& oc = other->ordered_connections;
    oc.erase(std::remove(oc.begin(), oc.end(), kf), oc.end());
    oc.push_back(kf);
    std::sort(oc.begin(), oc.end(), byWeightThenId(other));
  }
  kf->ordered_connections.clear();
  for (auto& [weight, other] : kept) kf->ordered_connections.push_back(other);
  std::sort(kf->ordered_connections.begin(), kf->ordered_connections.end(), byWeightThenId(kf));

  // Spanning tree: a new keyframe hangs from its strongest older neighbour.
  if (kf->parent == nullptr && kf->id != 0) {
    for (Keyframe* candidate : kf->ordered_connections) {
      if (candidate->id < kf->id && !candidate->bad) {
        kf->parent = candidate;
        candidate->children[kf->id] = kf;
        break;
      }
    }
  }
}

std::vector<Keyframe*> bestCovisibles(const Keyframe* kf, int n) {
  std::vector<Keyframe*> out;
  for (Keyframe* other : kf->ordered_connections) {
    if (n > 0 && static_cast<int>(out.size()) >= n) break;
    if (!other->bad) out.push_back(other);
  }
  return out;
}

std::vector<Keyframe*> covisiblesWithWeight(const Keyframe* kf, int min_weight) {
  std::vector<Keyframe*> out;
  for (Keyframe* other : kf->ordered_connections) {
    if (other->bad) continue;
    if (kf->connection_weights.at(other->id).second < min_weight) break;
    out.push_back(other);
  }
  return out;
}

int trackedPointCount(const Keyframe* kf, int min_observations) {
  int count = 0;
  for (const MapPoint* p : kf->points)
    if (p != nullptr && !p->bad && static_cast<int>(p->observations.size()) >= min_observations) ++count;
  return count;
}

int predictLevel(const MapPoint* point, double distance, const feature::ScalePyramid& pyramid) {
  const double ratio = point->max_distance / std::max(distance, 1e-9);
  if (pyramid.levels() <= 1) return 0;
  const int level = static_cast<int>(std::ceil(std::log(ratio) / pyramid.log_scale_factor));
  return std::clamp(level, 0, pyramid.levels() - 1);
}

SE3 keyframeTcw(const Keyframe* kf) {
  if (!kf->bad || kf->parent == nullptr) return kf->T_c_w;
  return kf->T_c_parent * keyframeTcw(kf->parent);
}

std::vector<bool> originsFixed(const std::vector<Keyframe*>& keyframes) {
  std::vector<bool> fixed(keyframes.size(), false);
  bool any = false;
  for (size_t i = 0; i < keyframes.size(); ++i) any = (fixed[i] = keyframes[i]->map_origin) || any;
  if (!any && !fixed.empty()) fixed[0] = true;
  return fixed;
}

std::vector<bool> globalBaFixed(const std::vector<Keyframe*>& keyframes) {
  std::vector<bool> fixed = originsFixed(keyframes);
  for (size_t i = 0; i < keyframes.size(); ++i) fixed[i] = fixed[i] || keyframes[i]->pose_held;
  return fixed;
}

}  // namespace desslam::map
