#include "matching/matcher.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "feature/descriptor.hpp"

namespace desslam::matching {

std::vector<bool> orientationConsistent(const std::vector<float>& angle_differences_deg) {
  constexpr int kBins = 30;
  std::array<int, kBins> histogram{};
  std::vector<int> bin_of(angle_differences_deg.size());
  for (size_t i = 0; i < angle_differences_deg.size(); ++i) {
    float d = std::fmod(angle_differences_deg[i], 360.0f);
    if (d < 0) d += 360.0f;
    const int bin = std::min(kBins - 1, static_cast<int>(d / (360.0f / kBins)));
    bin_of[i] = bin;
    ++histogram[bin];
  }
  // The three most populated bins; a bin far below the best (< 10 %) is not trusted.
  std::array<int, kBins> order{};
  for (int i = 0; i < kBins; ++i) order[i] = i;
  std::partial_sort(order.begin(), order.begin() + 3, order.end(),
                    [&](int a, int b) { return histogram[a] != histogram[b] ? histogram[a] > histogram[b] : a < b; });
  const int best = histogram[order[0]];
  std::array<bool, kBins> keep{};
  for (int k = 0; k < 3; ++k)
    if (histogram[order[k]] > 0 && histogram[order[k]] >= 0.1 * best) keep[order[k]] = true;
  std::vector<bool> result(angle_differences_deg.size());
  for (size_t i = 0; i < result.size(); ++i) result[i] = keep[bin_of[i]];
  return result;
}

int searchByProjection(map::Frame& frame, const PinholeCamera& camera,
                       const std::vector<ProjectionCandidate>& candidates, const MatcherOptions& options,
                       const ProjectionSearchScope& scope) {
  if (scope.eligible != nullptr && scope.eligible->size() != frame.features->size())
    throw std::invalid_argument("searchByProjection: the eligible list must have one entry per feature");
  const map::FeatureSet& features = *frame.features;
  std::vector<int> matched_feature;
  std::vector<float> angle_diff;
  std::vector<bool> uses_orientation;
  for (const ProjectionCandidate& c : candidates) {
    const Vec3 p_c = frame.T_c_w * c.p_w;
    if (p_c.z() <= 0.05) continue;
    const Vec2 uv = camera.project(p_c);
    if (!camera.inImage(uv)) continue;
    const std::vector<int> area = features.inArea(uv.x(), uv.y(), c.radius, c.min_level, c.max_level);
    int best = std::numeric_limits<int>::max(), second = std::numeric_limits<int>::max();
    int best_index = -1;
    for (int i : area) {
      const bool eligible = scope.eligible != nullptr ? (*scope.eligible)[i] != 0 : frame.usable(i);
      if (!eligible || frame.matches[i].matched()) continue;
      if (scope.max_relative_depth_residual > 0 &&
          (!features.hasDepth(i) || std::abs(1.0 - p_c.z() / features.depth[i]) > scope.max_relative_depth_residual))
        continue;
      if (features.hasDepth(i)) {
        // Depth must agree as well: compare virtual disparities, in pixels like the window.
        const double disparity_error = std::abs(camera.bf() / p_c.z() - camera.bf() / features.depth[i]);
        if (disparity_error > c.radius) continue;
      }
      const int d = feature::descriptorDistance(c.descriptor, features.descriptor(i));
      if (d < best) {
        second = best;
        best = d;
        best_index = i;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_index < 0 || best > options.max_distance) continue;
    if (second != std::numeric_limits<int>::max() && best > options.ratio * second) continue;
    map::FeatureMatch& m = frame.matches[best_index];
    m.point = c.point;
    m.has_vo_point = c.point == nullptr;
    m.vo_point = c.p_w;
    m.outlier = false;
    matched_feature.push_back(best_index);
    uses_orientation.push_back(c.angle >= 0);
    angle_diff.push_back(c.angle >= 0 ? c.angle - features.keypoints[best_index].angle : 0.0f);
  }
  int count = static_cast<int>(matched_feature.size());
  if (options.check_orientation && !matched_feature.empty()) {
    const std::vector<bool> keep = orientationConsistent(angle_diff);
    for (size_t k = 0; k < matched_feature.size(); ++k) {
      if (uses_orientation[k] && !keep[k]) {
        frame.matches[matched_feature[k]] = {};
        --count;
      }
    }
  }
  return count;
}

std::vector<std::pair<int, int>> matchDescriptors(const map::FeatureSet& a, const std::vector<int>& a_indices,
                                                  const map::FeatureSet& b, const std::vector<int>& b_indices,
                                                  int max_distance, double ratio, bool check_orientation,
                                                  const std::function<bool(int, int)>& accept) {
  // For each b feature, the best a feature so far (mutual uniqueness).
  std::vector<int> b_best_a(b.size(), -1);
  std::vector<int> b_best_distance(b.size(), std::numeric_limits<int>::max());
  for (int ia : a_indices) {
    const uint8_t* da = a.descriptor(ia);
    int best = std::numeric_limits<int>::max(), second = std::numeric_limits<int>::max();
    int best_b = -1;
    for (int ib : b_indices) {
      const int d = feature::descriptorDistance(da, b.descriptor(ib));
      if (d >= second) continue;
      if (accept && !accept(ia, ib)) continue;
      if (d < best) {
        second = best;
        best = d;
        best_b = ib;
      } else {
        second = d;
      }
    }
    if (best_b < 0 || best > max_distance) continue;
    if (second != std::numeric_limits<int>::max() && best > ratio * second) continue;
    if (best < b_best_distance[best_b]) {
      b_best_distance[best_b] = best;
      b_best_a[best_b] = ia;
    }
  }
  std::vector<std::pair<int, int>> matches;
  for (int ib : b_indices)
    if (b_best_a[ib] >= 0) matches.emplace_back(b_best_a[ib], ib);
  std::sort(matches.begin(), matches.end());
  if (check_orientation && !matches.empty()) {
    std::vector<float> diffs;
    for (auto [ia, ib] : matches) diffs.push_back(a.keypoints[ia].angle - b.keypoints[ib].angle);
    const std::vector<bool> keep = orientationConsistent(diffs);
    std::vector<std::pair<int, int>> kept;
    for (size_t k = 0; k < matches.size(); ++k)
      if (keep[k]) kept.push_back(matches[k]);
    matches.swap(kept);
  }
  return matches;
}

int fuseIntoKeyframe(map::Map& map, map::Keyframe* kf, const std::vector<map::MapPoint*>& points,
                     const PinholeCamera& camera, double radius, const MatcherOptions& options) {
  const map::FeatureSet& features = *kf->features;
  const auto& pyramid = *features.pyramid;
  const SE3 T_c_w = kf->T_c_w;
  const Vec3 center = kf->center();
  constexpr double kChi2Rgbd = 7.815;
  constexpr double kChi2Mono = 5.991;
  int fused = 0;
  for (map::MapPoint* p : points) {
    if (p == nullptr || p->bad || p->observations.count(kf->id) != 0) continue;
    const Vec3 p_c = T_c_w * p->position;
    if (p_c.z() <= 0.05) continue;
    const Vec2 uv = camera.project(p_c);
    if (!camera.inImage(uv)) continue;
    const Vec3 ray = p->position - center;
    const double distance = ray.norm();
    if (distance < 0.8 * p->min_distance || distance > 1.2 * p->max_distance) continue;
    if (ray.dot(p->normal) < 0.5 * distance) continue;  // viewing angle over 60 degrees
    const int level = map::predictLevel(p, distance, pyramid);
    const double r = radius * pyramid.scale[level];
    int best = std::numeric_limits<int>::max();
    int best_index = -1;
    for (int i : features.inArea(uv.x(), uv.y(), r, level - 1, level + 1)) {
      const int lvl = features.level(i);
      const Vec2 e = features.uv[i] - uv;
      double chi2 = e.squaredNorm();
      double threshold = kChi2Mono;
      if (features.hasDepth(i)) {
        const double er = camera.bf() / p_c.z() - camera.bf() / features.depth[i];
        chi2 += er * er;
        threshold = kChi2Rgbd;
      }
      if (chi2 * pyramid.inv_sigma2[lvl] > threshold) continue;
      const int d = feature::descriptorDistance(p->descriptor.ptr<uint8_t>(), features.descriptor(i));
      if (d < best) {
        best = d;
        best_index = i;
      }
    }
    if (best_index < 0 || best > options.strict_distance) continue;
    map::MapPoint* existing = kf->points[best_index];
    if (existing != nullptr && !existing->bad) {
      if (existing->observations.size() >= p->observations.size())
        replacePoint(map, p, existing);
      else
        replacePoint(map, existing, p);
    } else {
      map::addObservation(p, kf, best_index);
    }
    ++fused;
  }
  return fused;
}

}  // namespace desslam::matching
