#include "feature/orb_extractor.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "feature/descriptor.hpp"
#include "feature/keypoint_distribution.hpp"

namespace desslam::feature {
namespace {

constexpr int kPatchSize = 31;         // rBRIEF patch (pixels at the keypoint's level)
constexpr int kOrientationRadius = 15;  // intensity-centroid disc
// Keypoints keep this distance (level pixels) from the level border so that the orientation disc
// and the rotated rBRIEF pattern (up to ~15*sqrt(2) px, on a blurred image) stay inside it.
constexpr int kEdge = 19;
constexpr int kFastRadius = 3;  // FAST's Bresenham circle: no corner closer to a border

struct LevelCandidates {
  std::vector<cv::KeyPoint> keypoints;  // level pixel coordinates
  cv::Rect2f region;                    // where keypoints may lie
};

// FAST corners of one level: the whole level at the initial threshold, then cells of the grid that
// got nothing are searched again at the minimum threshold. One whole-image pass is cheaper than a
// pass per cell, and gives the same corners away from cell borders.
// exclude: empty, or a level-0 mask (nonzero = no keypoints there), `scale` = level-0 pixels per
// level pixel.
LevelCandidates detectLevel(const cv::Mat& image, const OrbOptions& options, const cv::Mat& exclude, double scale) {
  LevelCandidates out;
  const int width = image.cols - 2 * kEdge, height = image.rows - 2 * kEdge;
  if (width <= 0 || height <= 0) return out;
  out.region = cv::Rect2f(kEdge, kEdge, width, height);

  const int cols = std::max(1, static_cast<int>(std::lround(double(width) / options.cell_size)));
  const int rows = std::max(1, static_cast<int>(std::lround(double(height) / options.cell_size)));
  const float cell_w = float(width) / cols, cell_h = float(height) / rows;
  const auto cellOf = [&](const cv::Point2f& p) {
    const int c = std::min(cols - 1, static_cast<int>((p.x - kEdge) / cell_w));
    const int r = std::min(rows - 1, static_cast<int>((p.y - kEdge) / cell_h));
    return r * cols + c;
  };
  const auto inRegion = [&](const cv::Point2f& p) {
    if (p.x < kEdge || p.x >= kEdge + width || p.y < kEdge || p.y >= kEdge + height) return false;
    if (exclude.empty()) return true;
    const int x = std::min(exclude.cols - 1, static_cast<int>(p.x * scale + 0.5));
    const int y = std::min(exclude.rows - 1, static_cast<int>(p.y * scale + 0.5));
    return exclude.at<uint8_t>(y, x) == 0;
  };

  std::vector<cv::KeyPoint> found;
  cv::FAST(image, found, options.initial_fast_threshold, /*nonmaxSuppression=*/true);
  std::vector<uint8_t> occupied(static_cast<size_t>(cols * rows), 0);
  out.keypoints.reserve(found.size() + 64);
  for (const cv::KeyPoint& kp : found) {
    if (!inRegion(kp.pt)) continue;
    occupied[cellOf(kp.pt)] = 1;
    out.keypoints.push_back(kp);
  }

  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if (occupied[r * cols + c]) continue;
      const float x0 = kEdge + c * cell_w, y0 = kEdge + r * cell_h;
      const float x1 = c + 1 == cols ? kEdge + width : x0 + cell_w;
      const float y1 = r + 1 == rows ? kEdge + height : y0 + cell_h;
      if (!exclude.empty()) {
        // A cell wholly inside the excluded region has nothing to offer.
        const cv::Rect cell_level0 = cv::Rect(cv::Point(static_cast<int>(x0 * scale), static_cast<int>(y0 * scale)),
                                              cv::Point(static_cast<int>(std::ceil(x1 * scale)),
                                                        static_cast<int>(std::ceil(y1 * scale)))) &
                                     cv::Rect(0, 0, exclude.cols, exclude.rows);
        if (cell_level0.area() == 0 || cv::countNonZero(exclude(cell_level0)) == cell_level0.area()) continue;
      }
      // Widen by FAST's radius so corners on the cell's own border pixels can be found.
      const int rx0 = std::max(0, static_cast<int>(std::floor(x0)) - kFastRadius);
      const int ry0 = std::max(0, static_cast<int>(std::floor(y0)) - kFastRadius);
      const int rx1 = std::min(image.cols, static_cast<int>(std::ceil(x1)) + kFastRadius);
      const int ry1 = std::min(image.rows, static_cast<int>(std::ceil(y1)) + kFastRadius);
      found.clear();
      cv::FAST(image(cv::Range(ry0, ry1), cv::Range(rx0, rx1)), found, options.min_fast_threshold, true);
      for (cv::KeyPoint& kp : found) {
        kp.pt.x += rx0;
        kp.pt.y += ry0;
        if (kp.pt.x >= x0 && kp.pt.x < x1 && kp.pt.y >= y0 && kp.pt.y < y1 && inRegion(kp.pt))
          out.keypoints.push_back(kp);
      }
    }
  }
  return out;
}

// Caps each level's quota at what it can supply and hands the shortfall to the finer levels,
// which have the most corners, so the total stays num_features whenever the image allows it.
std::vector<int> levelQuotas(const std::vector<int>& wanted, const std::vector<LevelCandidates>& candidates) {
  std::vector<int> quota(wanted.size());
  int deficit = 0;
  for (size_t l = 0; l < wanted.size(); ++l) {
    const int available = static_cast<int>(candidates[l].keypoints.size());
    quota[l] = std::min(wanted[l], available);
    deficit += wanted[l] - quota[l];
  }
  for (size_t l = 0; l < wanted.size() && deficit > 0; ++l) {
    const int extra = std::min(deficit, static_cast<int>(candidates[l].keypoints.size()) - quota[l]);
    quota[l] += extra;
    deficit -= extra;
  }
  return quota;
}

}  // namespace

ScalePyramid makeScalePyramid(int num_levels, double scale_factor) {
  requireInRange(OrbOptions::kSection, "num_levels", num_levels, 1, 64);
  requireInRange(OrbOptions::kSection, "scale_factor", scale_factor, 1.0, 4.0);
  ScalePyramid p;
  p.scale_factor = scale_factor;
  p.log_scale_factor = std::log(scale_factor);
  for (int l = 0; l < num_levels; ++l) {
    const double s = std::pow(scale_factor, l);
    p.scale.push_back(s);
    p.inv_scale.push_back(1.0 / s);
    p.sigma2.push_back(s * s);
    p.inv_sigma2.push_back(1.0 / (s * s));
  }
  return p;
}

OrbExtractor::OrbExtractor(const OrbOptions& options) : options_(options) {
  options_.validate();
  pyramid_ = makeScalePyramid(options_.num_levels, options_.scale_factor);

  // Level l has 1/scale^(2l) of the pixels; its quota follows the same geometric series.
  const int levels = options_.num_levels;
  const double ratio = 1.0 / (options_.scale_factor * options_.scale_factor);
  const double first = options_.num_features * (1.0 - ratio) / (1.0 - std::pow(ratio, levels));
  int assigned = 0;
  for (int l = 0; l + 1 < levels; ++l) {
    const int n = static_cast<int>(std::lround(first * std::pow(ratio, l)));
    features_per_level_.push_back(n);
    assigned += n;
  }
  features_per_level_.push_back(std::max(0, options_.num_features - assigned));

  for (int dy = 0; dy <= kOrientationRadius; ++dy)
    circle_half_width_.push_back(
        static_cast<int>(std::floor(std::sqrt(double(kOrientationRadius * kOrientationRadius - dy * dy)))));
}

void OrbExtractor::extract(const cv::Mat& gray, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const {
  extractImpl(gray, cv::Mat(), features_per_level_, keypoints, descriptors);
}

void OrbExtractor::extractOutside(const cv::Mat& gray, const cv::Mat& exclude, int num_features,
                                  std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const {
  if (exclude.type() != CV_8UC1 || exclude.size() != gray.size())
    throw InputError("OrbExtractor::extractOutside: the exclusion mask must be CV_8UC1 of the image's size " +
                     std::to_string(gray.cols) + "x" + std::to_string(gray.rows));
  // The same split over levels as num_features, scaled.
  std::vector<int> wanted(features_per_level_.size());
  int assigned = 0;
  for (size_t l = 0; l + 1 < wanted.size(); ++l) {
    wanted[l] = static_cast<int>(std::lround(double(features_per_level_[l]) * num_features / options_.num_features));
    assigned += wanted[l];
  }
  wanted.back() = std::max(0, num_features - assigned);
  extractImpl(gray, exclude, wanted, keypoints, descriptors);
}

void OrbExtractor::extractImpl(const cv::Mat& gray, const cv::Mat& exclude, const std::vector<int>& wanted,
                               std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const {
  keypoints.clear();
  if (gray.empty() || gray.type() != CV_8UC1) {
    throw InputError("OrbExtractor::extract: expected a non-empty 8-bit single-channel (CV_8UC1) image, got " +
                     (gray.empty() ? std::string("an empty image") : "type " + cv::typeToString(gray.type())) +
                     "; convert colour images with cv::cvtColor(..., cv::COLOR_BGR2GRAY)");
  }
  const int levels = pyramid_.levels();

  std::vector<cv::Mat> images(levels);
  images[0] = gray;
  for (int l = 1; l < levels; ++l) {
    const cv::Size size(static_cast<int>(std::lround(gray.cols * pyramid_.inv_scale[l])),
                        static_cast<int>(std::lround(gray.rows * pyramid_.inv_scale[l])));
    if (size.width < 1 || size.height < 1) break;  // tiny input: the coarse levels stay empty
    cv::resize(images[l - 1], images[l], size, 0, 0, cv::INTER_LINEAR);
  }

  std::vector<LevelCandidates> candidates(levels);
  for (int l = 0; l < levels; ++l)
    if (!images[l].empty()) candidates[l] = detectLevel(images[l], options_, exclude, pyramid_.scale[l]);
  const std::vector<int> quota = levelQuotas(wanted, candidates);

  // Selected keypoints in level coordinates, level by level; class_id = output row.
  std::vector<std::vector<cv::KeyPoint>> selected(levels);
  int total = 0;
  for (int l = 0; l < levels; ++l) {
    const std::vector<cv::KeyPoint>& found = candidates[l].keypoints;
    for (int i : distributeKeypoints(found, candidates[l].region, quota[l])) {
      cv::KeyPoint kp = found[i];
      const int u = cvRound(kp.pt.x), v = cvRound(kp.pt.y);
      // Intensity centroid over a disc: the angle from the keypoint to the centroid makes the
      // descriptor rotation invariant (y grows downwards, like the rBRIEF pattern's rotation).
      long m10 = 0, m01 = 0;
      for (int dy = -kOrientationRadius; dy <= kOrientationRadius; ++dy) {
        const uint8_t* row = images[l].ptr<uint8_t>(v + dy);
        const int hw = circle_half_width_[std::abs(dy)];
        long sum = 0;
        for (int dx = -hw; dx <= hw; ++dx) {
          sum += row[u + dx];
          m10 += dx * row[u + dx];
        }
        m01 += dy * sum;
      }
      kp.angle = cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
      kp.octave = 0;  // cv::ORB is given one level at a time
      kp.size = kPatchSize;
      kp.class_id = total++;
      selected[l].push_back(kp);
    }
  }

  // rBRIEF via cv::ORB on each level image (our keypoints, our angles; it blurs the level first).
  // cv::ORB may drop keypoints near the border and regroups them by octave, so rows are mapped
  // back through class_id rather than trusted to keep their order.
  cv::Mat rows(total, kDescriptorBytes, CV_8U);
  std::vector<uint8_t> described(static_cast<size_t>(total), 0);
  const cv::Ptr<cv::ORB> orb = cv::ORB::create(std::max(1, total), 2.f, 1, kEdge, 0, 2, cv::ORB::FAST_SCORE,
                                               kPatchSize, options_.initial_fast_threshold);
  for (int l = 0; l < levels; ++l) {
    if (selected[l].empty()) continue;
    std::vector<cv::KeyPoint> level_keypoints = selected[l];
    cv::Mat level_descriptors;
    orb->compute(images[l], level_keypoints, level_descriptors);
    for (int k = 0; k < static_cast<int>(level_keypoints.size()); ++k) {
      const int row = level_keypoints[k].class_id;
      level_descriptors.row(k).copyTo(rows.row(row));
      described[row] = 1;
    }
  }

  keypoints.reserve(total);
  std::vector<int> kept_rows;
  kept_rows.reserve(total);
  for (int l = 0; l < levels; ++l) {
    const float scale = static_cast<float>(pyramid_.scale[l]);
    for (const cv::KeyPoint& kp : selected[l]) {
      if (!described[kp.class_id]) continue;
      kept_rows.push_back(kp.class_id);
      keypoints.emplace_back(kp.pt * scale, kPatchSize * scale, kp.angle, kp.response, l, -1);
    }
  }
  if (static_cast<int>(kept_rows.size()) == total) {
    descriptors = rows;
  } else {
    descriptors.create(static_cast<int>(kept_rows.size()), kDescriptorBytes, CV_8U);
    for (int k = 0; k < static_cast<int>(kept_rows.size()); ++k) rows.row(kept_rows[k]).copyTo(descriptors.row(k));
  }
}

int appendDistinctKeypoints(std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
                            const std::vector<cv::KeyPoint>& extra, const cv::Mat& extra_descriptors,
                            const ScalePyramid& pyramid) {
  const size_t existing = keypoints.size();
  std::vector<int> rows;
  for (size_t i = 0; i < extra.size(); ++i) {
    const cv::KeyPoint& e = extra[i];
    const double tolerance = pyramid.scale[std::clamp(e.octave, 0, pyramid.levels() - 1)];  // 1 level pixel
    bool duplicate = false;
    for (size_t k = 0; k < existing && !duplicate; ++k) {
      const cv::KeyPoint& kp = keypoints[k];
      duplicate = kp.octave == e.octave && std::abs(kp.pt.x - e.pt.x) <= tolerance &&
                  std::abs(kp.pt.y - e.pt.y) <= tolerance;
    }
    if (duplicate) continue;
    keypoints.push_back(e);
    rows.push_back(static_cast<int>(i));
  }
  if (rows.empty()) return 0;
  cv::Mat appended(static_cast<int>(rows.size()), extra_descriptors.cols, extra_descriptors.type());
  for (size_t r = 0; r < rows.size(); ++r) extra_descriptors.row(rows[r]).copyTo(appended.row(static_cast<int>(r)));
  if (descriptors.empty())
    descriptors = appended;
  else
    cv::vconcat(descriptors, appended, descriptors);
  return static_cast<int>(rows.size());
}

int topUpOutside(const OrbExtractor& extractor, const cv::Mat& gray, const cv::Mat& exclude, const cv::Mat& depth_m,
                 double min_depth_m, double max_depth_m, int wanted_with_depth, std::vector<cv::KeyPoint>& keypoints,
                 cv::Mat& descriptors) {
  if (wanted_with_depth <= 0) return 0;
  if (exclude.type() != CV_8UC1 || exclude.size() != gray.size())
    throw InputError("topUpOutside: the exclusion mask must be CV_8UC1 of the image's size " +
                     std::to_string(gray.cols) + "x" + std::to_string(gray.rows));
  if (!depth_m.empty() && (depth_m.type() != CV_32FC1 || depth_m.size() != gray.size()))
    throw InputError("topUpOutside: the depth image must be CV_32FC1 metres of the image's size " +
                     std::to_string(gray.cols) + "x" + std::to_string(gray.rows));
  // (outside the mask, of which with depth)
  const auto count = [&] {
    std::pair<int, int> n{0, 0};
    for (const cv::KeyPoint& kp : keypoints) {
      const int x = std::clamp(cvRound(kp.pt.x), 0, exclude.cols - 1);
      const int y = std::clamp(cvRound(kp.pt.y), 0, exclude.rows - 1);
      if (exclude.at<uint8_t>(y, x) != 0) continue;
      ++n.first;
      const float d = depth_m.empty() ? static_cast<float>(min_depth_m) : depth_m.at<float>(y, x);
      if (d >= min_depth_m && d <= max_depth_m) ++n.second;
    }
    return n;
  };
  // The depth-backed share of the keypoints outside only estimates that of the ones to come:
  // re-estimated after each round; a few rounds, and none once the texture gives nothing new.
  constexpr int kRounds = 3;
  int appended = 0;
  int last_requested = 0;
  for (int round = 0; round < kRounds; ++round) {
    const auto [outside, with_depth] = count();
    if (with_depth >= wanted_with_depth) break;
    // The floor keeps a view without depth from asking for an unbounded number of features.
    const double depth_share = outside > 0 ? std::max(0.25, double(with_depth) / outside) : 1.0;
    const int requested = outside + static_cast<int>(std::ceil((wanted_with_depth - with_depth) / depth_share));
    if (requested <= last_requested) break;  // the same request finds the same keypoints
    last_requested = requested;
    std::vector<cv::KeyPoint> extra;
    cv::Mat extra_descriptors;
    extractor.extractOutside(gray, exclude, requested, extra, extra_descriptors);
    const int added = appendDistinctKeypoints(keypoints, descriptors, extra, extra_descriptors, extractor.pyramid());
    appended += added;
    if (added == 0) break;
  }
  return appended;
}

}  // namespace desslam::feature
