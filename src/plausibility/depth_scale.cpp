#include "plausibility/depth_scale.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

#include "core/camera.hpp"
#include "feature/orb_extractor.hpp"

namespace desslam::plausibility {
namespace {

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  if (values.size() % 2 == 1) return *mid;
  const double upper = *mid;
  const double lower = *std::max_element(values.begin(), mid);
  return 0.5 * (lower + upper);
}

// ORB features of one frame: raw keypoints, their undistorted pixels and depth readings.
struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  std::vector<cv::Point2f> ideal;  // undistorted pixels
  std::vector<float> depth;        // metres at the raw keypoint (0: none)
};

Features extractFeatures(const CheckFrame& frame, const feature::OrbExtractor& extractor, const PinholeCamera& camera) {
  Features f;
  if (frame.gray.empty() || frame.gray.type() != CV_8UC1) return f;
  extractor.extract(frame.gray, f.keypoints, f.descriptors);
  std::vector<cv::Point2f> raw;
  raw.reserve(f.keypoints.size());
  for (const cv::KeyPoint& k : f.keypoints) raw.push_back(k.pt);
  f.ideal = camera.undistort(raw);
  f.depth.assign(f.keypoints.size(), 0.f);
  const bool has_depth = !frame.depth.empty() && frame.depth.type() == CV_32FC1 &&
                         frame.depth.size() == frame.gray.size();
  if (!has_depth) return f;
  for (size_t i = 0; i < raw.size(); ++i) {
    const int u = static_cast<int>(std::lround(raw[i].x)), v = static_cast<int>(std::lround(raw[i].y));
    if (u < 0 || v < 0 || u >= frame.depth.cols || v >= frame.depth.rows) continue;
    const float z = frame.depth.at<float>(v, u);
    if (z > 0 && std::isfinite(z)) f.depth[i] = z;
  }
  return f;
}

// Relative pose of the pair in depth units (PnP on the first frame's depth-backed features).
std::optional<PairMeasurement> measurePair(const CheckFrame& a_frame, const Features& a, const CheckFrame& b_frame,
                                           const Features& b, const PinholeCamera& camera) {
  if (a.descriptors.empty() || b.descriptors.empty()) return std::nullopt;
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(a.descriptors, b.descriptors, knn, 2);
  constexpr float kRatio = 0.8f;
  constexpr float kMaxDistance = 80.f;
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image, first_all, second_all;
  for (const auto& m : knn) {
    if (m.empty() || m[0].distance > kMaxDistance) continue;
    if (m.size() > 1 && m[0].distance >= kRatio * m[1].distance) continue;
    const int ia = m[0].queryIdx, ib = m[0].trainIdx;
    first_all.push_back(a.ideal[ia]);
    second_all.push_back(b.ideal[ib]);
    const float z = a.depth[ia];
    if (z <= 0) continue;
    const Vec3 p = camera.backProject(Vec2(a.ideal[ia].x, a.ideal[ia].y), z);
    object.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    image.push_back(b.ideal[ib]);
  }
  constexpr int kMinMatches = 20;
  if (static_cast<int>(object.size()) < kMinMatches) return std::nullopt;
  const cv::Mat K = camera.K();
  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const bool ok = cv::solvePnPRansac(object, image, K, cv::noArray(), rvec, tvec, false, 500, 2.0f, 0.999, inliers,
                                     cv::SOLVEPNP_EPNP);
  if (!ok || static_cast<int>(inliers.size()) < kMinMatches ||
      inliers.size() < 0.3 * static_cast<double>(object.size()))
    return std::nullopt;
  // Refine on the inliers (Levenberg-Marquardt from the RANSAC pose).
  std::vector<cv::Point3f> in_object;
  std::vector<cv::Point2f> in_image;
  for (int i : inliers) {
    in_object.push_back(object[static_cast<size_t>(i)]);
    in_image.push_back(image[static_cast<size_t>(i)]);
  }
  cv::solvePnPRefineLM(in_object, in_image, K, cv::noArray(), rvec, tvec);
  const Vec3 t_b_a(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  if (!t_b_a.allFinite()) return std::nullopt;

  PairMeasurement m;
  m.t_first = a_frame.timestamp;
  m.t_second = b_frame.timestamp;
  m.matches = static_cast<int>(object.size());
  m.inliers = static_cast<int>(inliers.size());
  m.depth_units = t_b_a.norm();  // |camera b's centre in a's frame| = |t|
  // Reference: camera a when its depth image was taken, camera b at its RGB time.
  const SE3 T_a_b = a_frame.T_w_c_depth->inverse() * *b_frame.T_w_c_rgb;
  m.reference_m = T_a_b.translation().norm();
  m.ratio = m.reference_m > 0 ? m.depth_units / m.reference_m : 0;

  // Depth-independent cross-check: the essential matrix's translation direction.
  if (first_all.size() >= 15 && t_b_a.norm() > 0) {
    cv::Mat mask;
    const cv::Mat E = cv::findEssentialMat(first_all, second_all, K, cv::RANSAC, 0.999, 1.0, mask);
    if (E.rows == 3 && E.cols == 3) {
      cv::Mat R, t;
      if (cv::recoverPose(E, first_all, second_all, K, R, t, mask) >= 15) {
        const Vec3 dir(t.at<double>(0), t.at<double>(1), t.at<double>(2));
        const double c = std::clamp(dir.normalized().dot(t_b_a.normalized()), -1.0, 1.0);
        if (std::isfinite(c)) m.direction_angle_deg = std::acos(c) * 180.0 / M_PI;
      }
    }
  }
  return m;
}

std::string formatted(double v, int precision = 3) {
  std::ostringstream s;
  s.precision(precision);
  s << v;
  return s.str();
}

}  // namespace

bool CheckResult::hasError() const {
  return std::any_of(findings.begin(), findings.end(), [](const Finding& f) { return f.error; });
}

std::string CheckResult::firstError() const {
  for (const Finding& f : findings)
    if (f.error) return f.message;
  return {};
}

nlohmann::json CheckResult::toJson() const {
  nlohmann::json pairs = nlohmann::json::array();
  for (const PairMeasurement& p : scale.pairs)
    pairs.push_back({{"t_first", p.t_first},
                     {"t_second", p.t_second},
                     {"matches", p.matches},
                     {"inliers", p.inliers},
                     {"reference_m", p.reference_m},
                     {"depth_units", p.depth_units},
                     {"ratio", p.ratio},
                     {"direction_angle_deg", p.direction_angle_deg}});
  nlohmann::json found = nlohmann::json::array();
  for (const Finding& f : findings)
    found.push_back({{"severity", f.error ? "error" : "warning"}, {"key", f.key}, {"message", f.message}});
  nlohmann::json j = {{"depth",
                       {{"frames", depth.frames},
                        {"valid_share", depth.valid_share},
                        {"median_m", depth.median_m},
                        {"p05_m", depth.p05_m},
                        {"p95_m", depth.p95_m}}},
                      {"scale",
                       {{"judged", scale.judged},
                        {"ratio", scale.ratio},
                        {"spread", scale.spread},
                        {"pairs_tried", scale.pairs_tried},
                        {"pairs_disagreeing", scale.pairs_disagreeing},
                        {"pairs", pairs}}},
                      {"findings", found}};
  if (!scale.not_judged.empty()) j["scale"]["not_judged"] = scale.not_judged;
  return j;
}

std::optional<SE3> interpolatePose(const Trajectory& trajectory, Timestamp t, double max_gap_s) {
  if (trajectory.empty() || !std::isfinite(t)) return std::nullopt;
  const auto after = std::lower_bound(trajectory.begin(), trajectory.end(), t,
                                      [](const StampedPose& p, Timestamp v) { return p.timestamp < v; });
  if (after != trajectory.end() && after->timestamp == t) return after->T_w_c;
  if (after == trajectory.begin() || after == trajectory.end()) return std::nullopt;
  const StampedPose& p1 = *after;
  const StampedPose& p0 = *(after - 1);
  const double gap = p1.timestamp - p0.timestamp;
  if (!(gap > 0) || gap > max_gap_s * (1 + 1e-9)) return std::nullopt;  // decimal stamps: 1.1 - 1.0 > 0.1
  const double s = (t - p0.timestamp) / gap;
  const Quat q = p0.T_w_c.quaternion().slerp(s, p1.T_w_c.quaternion());
  const Vec3 x = (1 - s) * p0.T_w_c.translation() + s * p1.T_w_c.translation();
  return SE3(q, x);
}

std::vector<size_t> selectFrames(const std::vector<Timestamp>& timestamps,
                                 const std::vector<std::optional<SE3>>& reference, const PlausibilityOptions& options) {
  std::vector<size_t> chosen;
  if (timestamps.empty()) return chosen;
  const size_t wanted = static_cast<size_t>(std::max(1, options.max_pairs));
  const auto spread = [&](const std::vector<size_t>& candidates) {
    std::vector<size_t> out;
    if (candidates.size() <= wanted) return candidates;
    for (size_t k = 0; k < wanted; ++k) out.push_back(candidates[(k + 1) * candidates.size() / wanted - 1]);
    return out;
  };
  size_t first = timestamps.size();
  if (reference.size() == timestamps.size())
    for (size_t i = 0; i < timestamps.size() && first == timestamps.size(); ++i)
      if (reference[i]) first = i;
  if (first == timestamps.size()) {  // no reference: depth range only, frames over window_s
    std::vector<size_t> within;
    for (size_t i = 1; i < timestamps.size() && timestamps[i] - timestamps[0] <= options.window_s; ++i)
      within.push_back(i);
    chosen.push_back(0);
    for (size_t i : spread(within)) chosen.push_back(i);
    return chosen;
  }
  const SE3& T_w_first = *reference[first];
  const auto moved = [&](double window) {
    std::vector<size_t> out;
    for (size_t i = first + 1; i < timestamps.size() && timestamps[i] - timestamps[first] <= window; ++i)
      if (reference[i] && (T_w_first.inverse() * *reference[i]).translation().norm() >= options.min_baseline_m)
        out.push_back(i);
    return out;
  };
  std::vector<size_t> candidates = moved(options.window_s);
  if (candidates.size() < wanted) candidates = moved(options.max_window_s);
  chosen.push_back(first);
  for (size_t i : spread(candidates)) chosen.push_back(i);
  return chosen;
}

DepthStatistics depthStatistics(const std::vector<cv::Mat>& depths) {
  DepthStatistics stats;
  std::vector<float> valid;
  size_t total = 0;
  for (const cv::Mat& depth : depths) {
    if (depth.empty() || depth.type() != CV_32FC1) continue;
    ++stats.frames;
    for (int r = 0; r < depth.rows; r += 2) {
      const float* row = depth.ptr<float>(r);
      for (int c = 0; c < depth.cols; c += 2) {
        ++total;
        if (row[c] > 0 && std::isfinite(row[c])) valid.push_back(row[c]);
      }
    }
  }
  if (total == 0 || valid.empty()) return stats;
  stats.valid_share = static_cast<double>(valid.size()) / static_cast<double>(total);
  const auto quantile = [&](double q) {
    const auto it = valid.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(valid.size() - 1));
    std::nth_element(valid.begin(), it, valid.end());
    return static_cast<double>(*it);
  };
  stats.median_m = quantile(0.5);
  stats.p05_m = quantile(0.05);
  stats.p95_m = quantile(0.95);
  return stats;
}

double suggestedDepthFactor(double depth_factor, double ratio) {
  const double raw = depth_factor * ratio;
  if (!(raw > 0) || !std::isfinite(raw)) return depth_factor;
  for (double common : {1000.0, 5000.0, 10000.0})
    if (std::abs(raw / common - 1.0) <= 0.1) return common;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)) - 1);
  return std::round(raw / magnitude) * magnitude;
}

CheckResult checkDepthScale(const std::vector<CheckFrame>& frames, const CameraOptions& camera_options,
                            const PlausibilityOptions& options) {
  CheckResult result;
  std::vector<cv::Mat> depths;
  for (const CheckFrame& f : frames) depths.push_back(f.depth);
  result.depth = depthStatistics(depths);
  const double factor = camera_options.depth_factor;
  const std::string factor_text = formatted(factor, 6);

  // The scale against the reference poses.
  ScaleEstimate& scale = result.scale;
  const bool referenced = frames.size() >= 2 && frames[0].T_w_c_depth && frames[0].T_w_c_rgb;
  if (!referenced) {
    scale.not_judged =
        "no ground truth (groundtruth.txt) for the first frames: the depth scale cannot be seen in the images "
        "alone (a k-times larger scene seen from a k-times longer path looks the same), only the depth range is "
        "checked";
  } else {
    const PinholeCamera camera(camera_options);
    OrbOptions orb;
    orb.num_features = 1500;
    const feature::OrbExtractor extractor(orb);
    const Features first = extractFeatures(frames[0], extractor, camera);
    std::vector<double> ratios, angles;
    for (size_t k = 1; k < frames.size(); ++k) {
      if (!frames[k].T_w_c_rgb) continue;
      ++scale.pairs_tried;
      const Features second = extractFeatures(frames[k], extractor, camera);
      const std::optional<PairMeasurement> m = measurePair(frames[0], first, frames[k], second, camera);
      if (!m || !(m->reference_m >= options.min_baseline_m) || !(m->ratio > 0) || !std::isfinite(m->ratio)) continue;
      if (m->direction_angle_deg > options.max_direction_disagreement_deg) {
        ++scale.pairs_disagreeing;
        continue;
      }
      scale.pairs.push_back(*m);
      ratios.push_back(m->ratio);
    }
    if (static_cast<int>(ratios.size()) < options.min_pairs) {
      scale.not_judged = "only " + std::to_string(ratios.size()) + " of " + std::to_string(scale.pairs_tried) +
                         " frame pairs could be measured (plausibility.min_pairs = " +
                         std::to_string(options.min_pairs) +
                         "; too little camera motion against the ground truth, or too few matched features with depth" +
                         (scale.pairs_disagreeing > 0
                              ? "; " + std::to_string(scale.pairs_disagreeing) +
                                    " pairs were measured but left out: their PnP and essential-matrix motions disagreed, "
                                    "people walking through?"
                              : std::string()) +
                         ")";
    } else {
      scale.ratio = median(ratios);
      std::vector<double> deviations;
      for (double r : ratios) deviations.push_back(std::abs(r - scale.ratio));
      scale.spread = median(deviations) / scale.ratio;
      if (scale.spread > options.max_spread)
        scale.not_judged = "the frame pairs disagree (spread " + formatted(100 * scale.spread) +
                           " %, more than plausibility.max_spread)";
      else
        scale.judged = true;
    }
  }

  const auto add = [&](bool error, const std::string& key, const std::string& message) {
    result.findings.push_back({error, key, message});
  };
  if (scale.judged) {
    const double r = scale.ratio;
    const double off = std::max(r, 1.0 / r);
    if (off >= options.warn_scale_error) {
      const bool error = off >= options.max_scale_error;
      const double suggestion = suggestedDepthFactor(factor, r);
      std::ostringstream msg;
      msg << "camera.depth_factor = " << factor_text << " does not fit this sequence: over its first "
          << formatted(scale.pairs.back().t_second - scale.pairs.front().t_first, 2) << " s the camera moved "
          << formatted(r) << " times as far in depth-image units as in the ground truth (PnP on depth-backed ORB "
          << "features against groundtruth.txt, median of " << scale.pairs.size() << " frame pairs, spread "
          << formatted(100 * scale.spread, 2) << " %), so the depth readings come out " << formatted(r) << "x too "
          << (r > 1 ? "large" : "small") << ". The likely factor is " << formatted(suggestion, 6) << " (measured: "
          << factor_text << " x " << formatted(r) << " = " << formatted(factor * r, 6)
          << "): set camera.depth_factor: " << formatted(suggestion, 6) << " in the config or --set camera.depth_factor="
          << formatted(suggestion, 6) << " (or fix the depth PNGs). ";
      if (error)
        msg << "If the depth is right (ground truth in other units?), `desslam run --force` turns this error into a "
               "warning.";
      else
        msg << "(A warning: errors start at " << formatted(options.max_scale_error) << "x, plausibility.max_scale_error.)";
      add(error, "camera.depth_factor", msg.str());
    }
  }
  if (result.depth.frames > 0 && result.depth.valid_share > 0 &&
      (result.depth.median_m < options.min_median_depth_m || result.depth.median_m > options.max_median_depth_m)) {
    std::ostringstream msg;
    msg << "camera.depth_factor = " << factor_text << ": the median depth reading of the first "
        << result.depth.frames << " frames is " << formatted(result.depth.median_m) << " m, implausible for an "
        << "indoor RGB-D camera (expected " << options.min_median_depth_m << "-" << options.max_median_depth_m
        << " m, plausibility.min/max_median_depth_m): check camera.depth_factor (5000 for TUM/Bonn, 1000 for "
           "millimetre PNGs)";
    if (!scale.judged) {
      const double typical = 2.0;  // metres: a typical indoor median, for a guess only
      msg << "; a factor near " << formatted(suggestedDepthFactor(factor, result.depth.median_m / typical), 6)
          << " would give a median of ~" << typical << " m";
    }
    msg << ". `desslam run --force` turns this error into a warning.";
    add(true, "camera.depth_factor", msg.str());
  }
  if (result.depth.frames > 0 && result.depth.valid_share < 0.05)
    add(false, "camera.depth_factor",
        "only " + formatted(100 * result.depth.valid_share, 2) + " % of the pixels of the first frames have a depth "
        "reading: is the camera covered, is the depth stream empty?");
  return result;
}

}  // namespace desslam::plausibility
