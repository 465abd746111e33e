#include "dynamic/depth_checks.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.hpp"
#include "dynamic/mask_utils.hpp"
#include "feature/descriptor.hpp"

namespace desslam::dynamic {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kSameSpotPx = 3.0;  // keypoints this close are one corner (mutual-match check)

int roundPixel(double v) { return static_cast<int>(std::lround(v)); }

// Median of the valid values gathered; the lower middle for an even count, so the result is
// always a real reading, never a depth halfway across an edge.
double medianOf(std::array<float, 9>& values, int count) {
  if (count == 0) return 0;
  std::sort(values.begin(), values.begin() + count);
  return values[(count - 1) / 2];
}

// Closest descriptor to feature `i` of set `from` among the features of `to` on nearby levels in
// a window around `predicted` (where `to` would see it if it were static); -1 when none is close
// enough or (with ratio_test) the best is ambiguous.
int bestInWindow(const map::FeatureSet& from, size_t i, const map::FeatureSet& to, const Vec2& predicted,
                 const DynamicOptions& options, bool ratio_test) {
  const int level = from.level(i);
  const double scale = from.pyramid && level < from.pyramid->levels() ? from.pyramid->scale[level] : 1.0;
  const std::vector<int> candidates = to.inArea(predicted.x(), predicted.y(), options.stage1_search_radius_px * scale,
                                                std::max(0, level - 1), level + 1);
  int best = feature::kMaxDescriptorDistance + 1, second = feature::kMaxDescriptorDistance + 1, best_index = -1;
  for (int j : candidates) {
    const int d = feature::descriptorDistance(from.descriptor(i), to.descriptor(j));
    if (d < best) {
      second = best;
      best = d;
      best_index = j;
    } else if (d < second) {
      second = d;
    }
  }
  if (best_index < 0 || best > options.stage1_max_descriptor_distance) return -1;
  // Ambiguous (repeated texture): a wrong correspondence would invent a depth change.
  if (ratio_test && second <= feature::kMaxDescriptorDistance && best >= options.stage1_match_ratio * second)
    return -1;
  return best_index;
}

// Index of the frame k-1 feature matching current feature i, or -1. The match must be mutual:
// searched back from frame k-1 (around where its own depth puts it in frame k), the closest is i
// again. A static point just uncovered by a moving person has no counterpart in frame k-1; a
// one-way search would pair it with some lookalike on the person and call it dynamic.
int matchInPrevious(const map::FeatureSet& current, size_t i, const map::FeatureSet& previous, const SE3& T_k_km1,
                    const SE3& T_km1_k, const PinholeCamera& camera, const DynamicOptions& options) {
  const Vec3 p_km1 = T_km1_k * camera.backProject(current.uv[i], current.depth[i]);
  if (p_km1.z() <= 0) return -1;
  const int j = bestInWindow(current, i, previous, camera.project(p_km1), options, true);
  if (j < 0) return -1;
  // Back in frame k: where frame k-1's depth puts j, or, without depth, around i itself.
  Vec2 back = current.uv[i];
  if (previous.hasDepth(static_cast<size_t>(j))) {
    const Vec3 p_k = T_k_km1 * camera.backProject(previous.uv[j], previous.depth[j]);
    if (p_k.z() > 0) back = camera.project(p_k);
  }
  // The back search window must contain i even when the object moved.
  if ((back - current.uv[i]).norm() > options.stage1_search_radius_px) back = current.uv[i];
  // The ratio test was passed one way; back, the closest only has to be i or a feature at i's
  // spot (the same corner detected on another pyramid level).
  const int i_back = bestInWindow(previous, static_cast<size_t>(j), current, back, options, false);
  if (i_back < 0) return -1;
  return (current.uv[static_cast<size_t>(i_back)] - current.uv[i]).norm() <= kSameSpotPx ? j : -1;
}

void requireDepth(const cv::Mat* depth, const char* what) {
  if (depth == nullptr || depth->empty() || depth->type() != CV_32FC1)
    throw InputError(std::string(what) + ": expected a CV_32F depth image in metres");
}

}  // namespace

double relativeDepthResidual(double observed, double predicted) { return std::abs(1.0 - predicted / observed); }

bool exceeds(double residual, double threshold) { return residual > threshold; }

double medianDepth3x3(const cv::Mat& depth_m, int x, int y) {
  if (x < 0 || y < 0 || x >= depth_m.cols || y >= depth_m.rows) return 0;
  std::array<float, 9> values{};
  int count = 0;
  for (int yy = std::max(0, y - 1); yy <= std::min(depth_m.rows - 1, y + 1); ++yy) {
    const float* row = depth_m.ptr<float>(yy);
    for (int xx = std::max(0, x - 1); xx <= std::min(depth_m.cols - 1, x + 1); ++xx)
      if (row[xx] > 0) values[count++] = row[xx];
  }
  return medianOf(values, count);
}

Stage1Result runStage1(const Stage1Input& input, const PinholeCamera& camera, const DynamicOptions& options) {
  if (input.current == nullptr || input.previous == nullptr)
    throw InputError("runStage1: the current and previous feature sets are required");
  requireDepth(input.current_depth, "runStage1 current_depth");
  const map::FeatureSet& current = *input.current;
  const map::FeatureSet& previous = *input.previous;
  const cv::Mat& depth_k = *input.current_depth;
  const size_t n = current.size();
  if (input.previous_match != nullptr && input.previous_match->size() != n)
    throw InputError("runStage1: previous_match has " + std::to_string(input.previous_match->size()) +
                     " entries for " + std::to_string(n) + " features");

  Stage1Result r;
  r.outcome.assign(n, Stage1Outcome::kNotChecked);
  r.dynamic.assign(n, 0);
  r.previous_index.assign(n, -1);
  r.residual_forward.assign(n, kNaN);
  r.residual_sideways.assign(n, kNaN);
  r.residual.assign(n, kNaN);
  if (input.mask != nullptr && !input.mask->empty()) {
    if (input.mask->size() != depth_k.size())
      throw InputError("runStage1: the mask and the depth image differ in size");
    r.in_mask = featuresInMask(current, input.mask_is_dilated ? *input.mask
                                                               : dilateMask(*input.mask, options.mask_dilation_px));
  } else {
    r.in_mask.assign(n, 1);  // geometric-only mode: every feature is a candidate
  }

  const bool drop_unchecked = options.stage1_unmatched_policy == UnmatchedPolicy::kDrop;
  const SE3 T_km1_k = input.T_k_km1.inverse();
  for (size_t i = 0; i < n; ++i) {
    if (!r.in_mask[i]) continue;
    ++r.in_mask_count;
    Stage1Outcome& outcome = r.outcome[i];
    int j = -1;
    if (!current.hasDepth(i)) {
      outcome = Stage1Outcome::kNoDepth;
    } else {
      j = input.previous_match ? (*input.previous_match)[i]
                               : matchInPrevious(current, i, previous, input.T_k_km1, T_km1_k, camera, options);
      if (j < 0 || static_cast<size_t>(j) >= previous.size()) {
        j = -1;
        outcome = Stage1Outcome::kUnmatched;
      } else if (!previous.hasDepth(static_cast<size_t>(j))) {
        outcome = Stage1Outcome::kNoDepth;
      }
    }
    r.previous_index[i] = j;
    if (outcome != Stage1Outcome::kNotChecked) {  // no depth or no match: policy decides
      if (outcome == Stage1Outcome::kNoDepth) ++r.no_depth_count; else ++r.unmatched_count;
      r.dynamic[i] = drop_unchecked ? 1 : 0;
      continue;
    }

    const Vec3 p_k = input.T_k_km1 * camera.backProject(previous.uv[j], previous.depth[j]);
    const double d_proj = p_k.z();
    const double forward = relativeDepthResidual(current.depth[i], d_proj);
    r.residual_forward[i] = forward;
    double worst = forward;
    if (d_proj > 0) {
      const Vec2 x_prime = camera.project(p_k);
      if (camera.inImage(x_prime)) {
        const Vec2 raw = camera.distort(x_prime);
        const double z_there = medianDepth3x3(depth_k, roundPixel(raw.x()), roundPixel(raw.y()));
        // Only "seen through" counts (z_there > d_proj): a nearer surface at x' hides the point
        // there, which a static point beside a person's silhouette shows whenever x' falls a
        // pixel onto the person; that is no evidence of motion (same rule as stage 2).
        if (z_there > 0) {
          r.residual_sideways[i] = relativeDepthResidual(z_there, d_proj);
          if (z_there > d_proj) worst = std::max(worst, r.residual_sideways[i]);
        }
      }
    }
    r.residual[i] = worst;
    // A static point re-projects onto the feature it matched; one that lands farther away moved
    // in the image even when its depth happens to agree (e.g. a matched patch of the same person
    // a few centimetres further along).
    const double reprojection_limit = options.stage1_max_reprojection_px * current.pyramid->scale[current.level(i)];
    const bool moved_in_image =
        d_proj <= 0 || (camera.project(p_k) - current.uv[i]).norm() > reprojection_limit;
    if (exceeds(worst, options.stage1_threshold) || moved_in_image) {
      outcome = Stage1Outcome::kDynamic;
      r.dynamic[i] = 1;
      ++r.dynamic_count;
    } else {
      outcome = Stage1Outcome::kConsistent;
      ++r.consistent_count;
    }
  }
  r.removed_count = static_cast<int>(std::count(r.dynamic.begin(), r.dynamic.end(), 1));
  return r;
}

std::vector<uint8_t> freeSpaceViolations(const FreeSpaceInput& input, const PinholeCamera& camera,
                                         const DynamicOptions& options) {
  if (input.current == nullptr) throw InputError("freeSpaceViolations: the current feature set is required");
  requireDepth(input.reference_depth, "freeSpaceViolations reference_depth");
  const map::FeatureSet& current = *input.current;
  const cv::Mat& depth = *input.reference_depth;
  const size_t n = current.size();
  if (input.test != nullptr && input.test->size() != n)
    throw InputError("freeSpaceViolations: test has " + std::to_string(input.test->size()) + " entries for " +
                     std::to_string(n) + " features");
  if (input.depth_scale < 1) throw InputError("freeSpaceViolations: depth_scale must be at least 1");
  const int window_radius = std::max(1, 2 / input.depth_scale);  // ~5x5 pixels of the full image
  std::vector<uint8_t> dynamic(n, 0);
  for (size_t i = 0; i < n; ++i) {
    if ((input.test != nullptr && !(*input.test)[i]) || !current.hasDepth(i)) continue;
    const Vec3 p_ref = input.T_ref_k * camera.backProject(current.uv[i], current.depth[i]);
    const double d_ref = p_ref.z();
    if (d_ref <= 0) continue;
    const Vec2 uv = camera.project(p_ref);
    if (!camera.inImage(uv)) continue;
    const Vec2 raw = camera.distort(uv);
    const int x = roundPixel(raw.x() / input.depth_scale), y = roundPixel(raw.y() / input.depth_scale);
    float nearest = 0;
    for (int yy = std::max(0, y - window_radius); yy <= std::min(depth.rows - 1, y + window_radius); ++yy) {
      const float* row = depth.ptr<float>(yy);
      for (int xx = std::max(0, x - window_radius); xx <= std::min(depth.cols - 1, x + window_radius); ++xx)
        if (row[xx] > 0 && (nearest <= 0 || row[xx] < nearest)) nearest = row[xx];
    }
    if (nearest <= 0 || nearest <= d_ref) continue;
    if (exceeds(relativeDepthResidual(nearest, d_ref), options.stage1_threshold)) dynamic[i] = 1;
  }
  return dynamic;
}

cv::Mat makeHalfResolutionDepth(const cv::Mat& depth_m) {
  if (depth_m.empty() || depth_m.type() != CV_32FC1)
    throw InputError("makeHalfResolutionDepth: expected a CV_32F depth image in metres");
  cv::Mat half((depth_m.rows + 1) / 2, (depth_m.cols + 1) / 2, CV_32FC1, cv::Scalar(0));
  for (int y = 0; y < depth_m.rows; ++y) {
    const float* row = depth_m.ptr<float>(y);
    float* out = half.ptr<float>(y / 2);
    for (int x = 0; x < depth_m.cols; ++x) {
      const float d = row[x];
      if (d <= 0) continue;
      float& o = out[x / 2];
      if (o <= 0 || d < o) o = d;
    }
  }
  return half;
}

double sampleHalfResolutionDepth(const cv::Mat& half_depth, const Vec2& uv, const PinholeCamera& camera) {
  const Vec2 raw = camera.distort(uv);
  const int x = roundPixel(raw.x()), y = roundPixel(raw.y());
  if (x < 0 || y < 0) return 0;
  return medianDepth3x3(half_depth, x / 2, y / 2);
}

Stage2Decision checkStage2(const Vec3& point_w, const std::vector<KeyframeDepthView>& views,
                           const PinholeCamera& camera, const DynamicOptions& options) {
  Stage2Decision decision;
  std::vector<double> residuals;
  for (const KeyframeDepthView& view : views) {
    if (decision.keyframes_checked >= options.stage2_keyframes) break;
    requireDepth(view.half_depth, "checkStage2 half_depth");
    const Vec3 p_r = view.T_c_w * point_w;
    const double d_r = p_r.z();
    if (d_r <= 0) continue;
    const Vec2 uv = camera.project(p_r);
    if (!camera.inImage(uv)) continue;
    const double z_r = sampleHalfResolutionDepth(*view.half_depth, uv, camera);
    if (z_r <= 0) continue;
    const double residual = relativeDepthResidual(z_r, d_r);
    const bool inconsistent = exceeds(residual, options.stage2_threshold);
    if (inconsistent && z_r < d_r) {  // something in front of the point: occluded, no evidence
      ++decision.keyframes_occluded;
      continue;
    }
    ++decision.keyframes_checked;
    if (inconsistent) ++decision.keyframes_inconsistent;
    residuals.push_back(residual);
  }
  if (!residuals.empty()) {
    const auto mid = residuals.begin() + static_cast<long>(residuals.size() / 2);
    std::nth_element(residuals.begin(), mid, residuals.end());
    decision.median_residual = *mid;
  }
  decision.dynamic = decision.keyframes_checked >= 1 &&
                     2 * decision.keyframes_inconsistent > decision.keyframes_checked;
  return decision;
}

}  // namespace desslam::dynamic
