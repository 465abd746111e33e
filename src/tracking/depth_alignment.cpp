#include "tracking/depth_alignment.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "core/option_fields.hpp"

namespace desslam::tracking {

void DepthAlignmentOptions::validate() const {
  const char* s = "depth_alignment";
  requireInRange(s, "min_depth_m", min_depth_m, 0.0, 10.0);
  requireInRange(s, "max_depth_m", max_depth_m, min_depth_m, 100.0);
  requireInRange(s, "finest_level", finest_level, 0, 4);
  requireThat(!iterations.empty() && iterations.size() <= 4 &&
                  std::all_of(iterations.begin(), iterations.end(), [](int n) { return n >= 1 && n <= 100; }),
              s, "iterations", "expected 1-4 levels of 1-100 iterations each");
  requireInRange(s, "max_point_distance_m", max_point_distance_m, 1e-4, 10.0);
  requireInRange(s, "max_normal_angle_deg", max_normal_angle_deg, 1.0, 90.0);
  requireInRange(s, "huber_m", huber_m, 1e-5, 1.0);
  requireInRange(s, "min_correspondences", min_correspondences, 6, 10000000);
  requireInRange(s, "min_overlap", min_overlap, 0.0, 1.0);
  requireInRange(s, "max_rms_m", max_rms_m, 1e-5, 1.0);
  requireInRange(s, "min_constraint", min_constraint, 0.0, 1.0);
}

namespace {

// A cell's depth: the mean of its readings when at least half of its pixels have one in range,
// none is masked and they agree within 3 % (a cell across a depth edge has no point).
bool cellDepth(const cv::Mat& depth, const cv::Mat& mask, int x0, int y0, int scale, const DepthAlignmentOptions& o,
               double& z) {
  double sum = 0, lo = 1e9, hi = 0;
  int n = 0;
  for (int y = y0; y < y0 + scale; ++y) {
    const float* d = depth.ptr<float>(y);
    const uint8_t* m = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    for (int x = x0; x < x0 + scale; ++x) {
      if (m != nullptr && m[x] != 0) return false;
      const double v = d[x];
      if (!(v >= o.min_depth_m && v <= o.max_depth_m)) continue;
      sum += v;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
      ++n;
    }
  }
  if (2 * n < scale * scale || hi - lo > 0.03 * lo) return false;
  z = sum / n;
  return true;
}

}  // namespace

DepthAligner::DepthAligner(const PinholeCamera& camera, const DepthAlignmentOptions& options)
    : camera_(camera), options_(options) {
  options_.validate();
  const int top = options_.finest_level + static_cast<int>(options_.iterations.size()) - 1;
  rays_.resize(static_cast<size_t>(top) + 1);
  for (int l = options_.finest_level; l <= top; ++l) {
    const int scale = 1 << l;
    const int width = camera_.width() / scale, height = camera_.height() / scale;
    std::vector<cv::Point2f> raw;
    raw.reserve(static_cast<size_t>(width) * height);
    const float centre = 0.5f * static_cast<float>(scale - 1);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u)
        raw.emplace_back(static_cast<float>(u * scale) + centre, static_cast<float>(v * scale) + centre);
    for (const cv::Point2f& p : camera_.undistort(raw)) rays_[static_cast<size_t>(l)].emplace_back(p.x, p.y);
  }
}

DepthPyramid DepthAligner::prepare(const cv::Mat& depth, const cv::Mat& mask) const {
  DepthPyramid pyramid;
  if (depth.empty() || depth.type() != CV_32F) return pyramid;
  const cv::Mat use_mask = (!mask.empty() && mask.size() == depth.size() && mask.type() == CV_8U) ? mask : cv::Mat();
  pyramid.levels.resize(rays_.size());
  for (int l = options_.finest_level; l < static_cast<int>(rays_.size()); ++l) {
    DepthPyramid::Level& level = pyramid.levels[static_cast<size_t>(l)];
    level.scale = 1 << l;
    level.width = std::min(depth.cols, camera_.width()) / level.scale;
    level.height = std::min(depth.rows, camera_.height()) / level.scale;
    const std::vector<Vec2>& rays = rays_[static_cast<size_t>(l)];
    const int ray_width = camera_.width() / level.scale;
    const size_t n = static_cast<size_t>(level.width) * static_cast<size_t>(level.height);
    level.points.assign(n, Vec3::Zero());
    level.normals.assign(n, Vec3::Zero());
    for (int v = 0; v < level.height; ++v)
      for (int u = 0; u < level.width; ++u) {
        double z = 0;
        if (!cellDepth(depth, use_mask, u * level.scale, v * level.scale, level.scale, options_, z)) continue;
        level.points[static_cast<size_t>(v) * level.width + u] =
            camera_.backProject(rays[static_cast<size_t>(v) * ray_width + u], z);
      }
    // Normals from the neighbours two cells away on each side (one cell's depth noise at 3 m is
    // about the cell spacing there), facing the camera; none across a depth edge.
    const int k = 2;
    for (int v = k; v + k < level.height; ++v)
      for (int u = k; u + k < level.width; ++u) {
        const size_t i = static_cast<size_t>(v) * level.width + u;
        const size_t row = static_cast<size_t>(k) * level.width;
        const Vec3& p = level.points[i];
        const Vec3& l = level.points[i - k];
        const Vec3& r = level.points[i + k];
        const Vec3& up = level.points[i - row];
        const Vec3& down = level.points[i + row];
        if (p.z() <= 0 || l.z() <= 0 || r.z() <= 0 || up.z() <= 0 || down.z() <= 0) continue;
        const double edge = 0.05 * k * p.z();
        if (std::abs(l.z() - r.z()) > 2 * edge || std::abs(up.z() - down.z()) > 2 * edge) continue;
        Vec3 normal = (r - l).cross(down - up);
        const double norm = normal.norm();
        if (norm <= 0) continue;
        normal /= norm;
        if (normal.dot(p) > 0) normal = -normal;
        level.normals[i] = normal;
        ++level.usable;
      }
  }
  return pyramid;
}

namespace {

// Weight of the prior on the guess per pair, against the constraint's 0 (unseen) to 1/3 (seen
// from every side): 15 times below DepthAlignmentOptions::min_constraint's default.
constexpr double kPriorWeight = 1e-3;

struct Accumulated {
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();  // weighted
  Vec6 g = Vec6::Zero();
  Eigen::Matrix<double, 6, 6> H_plain = Eigen::Matrix<double, 6, 6>::Zero();  // unweighted, for the constraint
  int pairs = 0;
  double sum_r2 = 0;
  double sum_depth = 0;
};

// One pass of projective association: every usable point of `cur` moved by T_ref_cur, looked up
// in `ref` where it projects, paired when close and facing the same way.
Accumulated associate(const DepthPyramid::Level& ref, const DepthPyramid::Level& cur, const PinholeCamera& camera,
                      const SE3& T_ref_cur, double max_distance_m, double min_normal_cos, double huber_m) {
  Accumulated a;
  const Mat3 R = T_ref_cur.rotation();
  const Vec3 t = T_ref_cur.translation();
  const double centre = 0.5 * (ref.scale - 1);
  for (size_t i = 0; i < cur.points.size(); ++i) {
    const Vec3& n_cur = cur.normals[i];
    if (n_cur.isZero()) continue;
    const Vec3 p = R * cur.points[i] + t;
    if (p.z() <= 0) continue;
    const Vec2 raw = camera.distort(camera.project(p));
    const int u = static_cast<int>(std::lround((raw.x() - centre) / ref.scale));
    const int v = static_cast<int>(std::lround((raw.y() - centre) / ref.scale));
    if (u < 0 || v < 0 || u >= ref.width || v >= ref.height) continue;
    const size_t j = static_cast<size_t>(v) * ref.width + u;
    const Vec3& n = ref.normals[j];
    if (n.isZero()) continue;
    const Vec3 d = p - ref.points[j];
    if (d.norm() > max_distance_m || (R * n_cur).dot(n) < min_normal_cos) continue;
    const double r = n.dot(d);
    const double w = std::abs(r) <= huber_m ? 1.0 : huber_m / std::abs(r);
    Vec6 J;
    J.head<3>() = n;
    J.tail<3>() = p.cross(n);
    a.H.noalias() += w * J * J.transpose();
    a.g.noalias() += w * r * J;
    a.H_plain.noalias() += J * J.transpose();
    ++a.pairs;
    a.sum_r2 += r * r;
    a.sum_depth += p.z();
  }
  return a;
}

}  // namespace

DepthAlignmentResult DepthAligner::align(const DepthPyramid& ref, const DepthPyramid& cur,
                                         const SE3& T_cur_ref_guess) const {
  const DepthAlignmentOptions& options = options_;
  const PinholeCamera& camera = camera_;
  DepthAlignmentResult result;
  result.T_cur_ref = T_cur_ref_guess;
  const int top = options.finest_level + static_cast<int>(options.iterations.size()) - 1;
  if (static_cast<int>(ref.levels.size()) <= top || static_cast<int>(cur.levels.size()) <= top ||
      ref.levels[static_cast<size_t>(top)].width != cur.levels[static_cast<size_t>(top)].width) {
    result.refusal = "no depth";
    return result;
  }
  const double min_normal_cos = std::cos(options.max_normal_angle_deg * M_PI / 180.0);
  const SE3 T_ref_cur_guess = T_cur_ref_guess.inverse();
  SE3 T_ref_cur = T_ref_cur_guess;
  for (int l = top; l >= options.finest_level; --l) {
    const double max_distance = options.max_point_distance_m * static_cast<double>(1 << (l - options.finest_level));
    const int iterations = options.iterations[static_cast<size_t>(top - l)];
    for (int it = 0; it < iterations; ++it) {
      const Accumulated a = associate(ref.levels[static_cast<size_t>(l)], cur.levels[static_cast<size_t>(l)], camera,
                                      T_ref_cur, max_distance, min_normal_cos, options.huber_m);
      if (a.pairs < 6) {
        result.refusal = "too few correspondences";
        return result;
      }
      // A weak prior on the guess (kPriorWeight per pair, rotation scaled by the mean depth as
      // for the constraint): a motion the depth hardly sees stays at the guess instead of taking
      // the noise's direction (a corner seen at a grazing angle slid 12 cm in one step without it).
      const double z = a.sum_depth / a.pairs;
      Vec6 prior_scale;
      prior_scale << 1, 1, 1, z * z, z * z, z * z;
      const Vec6 deviation = (T_ref_cur * T_ref_cur_guess.inverse()).log();
      const Vec6 prior = kPriorWeight * a.pairs * prior_scale;
      const Eigen::Matrix<double, 6, 6> H = a.H + Eigen::Matrix<double, 6, 6>(prior.asDiagonal());
      const Vec6 step = H.ldlt().solve(-(a.g + prior.cwiseProduct(deviation)));
      if (!step.allFinite()) {
        result.refusal = "singular";
        return result;
      }
      T_ref_cur = SE3::exp(step) * T_ref_cur;
      if (step.head<3>().norm() < 1e-5 && step.tail<3>().norm() < 1e-5) break;
    }
  }
  // The pairs at the estimate, for the acceptance bounds.
  const size_t finest = static_cast<size_t>(options.finest_level);
  const Accumulated last = associate(ref.levels[finest], cur.levels[finest], camera, T_ref_cur,
                                     options.max_point_distance_m, min_normal_cos, options.huber_m);
  result.T_cur_ref = T_ref_cur.inverse();
  result.correspondences = last.pairs;
  const int usable = cur.levels[finest].usable;
  result.overlap = usable > 0 ? static_cast<double>(last.pairs) / usable : 0.0;
  if (last.pairs > 0) {
    result.rms_m = std::sqrt(last.sum_r2 / last.pairs);
    // Rotation scaled by the mean depth: a rotation of 1/z moves points by about one unit there.
    const double z = last.sum_depth / last.pairs;
    Vec6 scale;
    scale << 1, 1, 1, 1 / z, 1 / z, 1 / z;
    const Eigen::Matrix<double, 6, 6> M = scale.asDiagonal() * last.H_plain * scale.asDiagonal() / last.pairs;
    result.constraint = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(M).eigenvalues().minCoeff();
  }
  if (result.correspondences < options.min_correspondences)
    result.refusal = "too few correspondences";
  else if (result.overlap < options.min_overlap)
    result.refusal = "too little overlap";
  else if (result.rms_m > options.max_rms_m)
    result.refusal = "residual too large";
  else if (result.constraint < options.min_constraint)
    result.refusal = "motion not constrained (one plane)";
  result.accepted = *result.refusal == '\0';
  return result;
}

}  // namespace desslam::tracking
