#include "eval/alignment.hpp"

#include <string>

#include <Eigen/SVD>

#include "core/error.hpp"

namespace desslam::eval {
namespace {

// Second singular value of the cross-covariance relative to the first below this: the points
// are collinear (or coincident) up to rounding, and rotations about the line fit equally well.
constexpr double kRankTolerance = 1e-10;

struct CrossCovariance {
  Vec3 mean_est = Vec3::Zero();
  Vec3 mean_gt = Vec3::Zero();
  Mat3 sigma = Mat3::Zero();  // (1/n) sum (gt_i - mean_gt)(est_i - mean_est)^T
};

CrossCovariance crossCovariance(const std::vector<Vec3>& est_points, const std::vector<Vec3>& gt_points) {
  if (est_points.size() != gt_points.size())
    throw InputError("alignRigid: " + std::to_string(est_points.size()) + " estimate points but " +
                     std::to_string(gt_points.size()) + " ground-truth points; pass associated pairs");
  if (est_points.size() < 3)
    throw InputError("alignRigid: " + std::to_string(est_points.size()) +
                     " point pairs; a rigid alignment needs at least 3 non-collinear points");
  CrossCovariance c;
  const double n = static_cast<double>(est_points.size());
  for (std::size_t i = 0; i < est_points.size(); ++i) {
    c.mean_est += est_points[i];
    c.mean_gt += gt_points[i];
  }
  c.mean_est /= n;
  c.mean_gt /= n;
  for (std::size_t i = 0; i < est_points.size(); ++i)
    c.sigma += (gt_points[i] - c.mean_gt) * (est_points[i] - c.mean_est).transpose();
  c.sigma /= n;
  return c;
}

bool hasFullRankRotationInfo(const Vec3& singular_values) {
  return singular_values(0) > 0 && singular_values(1) > kRankTolerance * singular_values(0);
}

}  // namespace

SE3 alignRigid(const std::vector<Vec3>& est_points, const std::vector<Vec3>& gt_points, DegenerateInput degenerate) {
  const CrossCovariance c = crossCovariance(est_points, gt_points);
  const Eigen::JacobiSVD<Mat3> svd(c.sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  if (degenerate == DegenerateInput::kThrow && !hasFullRankRotationInfo(svd.singularValues()))
    throw InputError("alignRigid: the points are collinear or coincident, so the rotation is not determined; "
                     "need at least 3 non-collinear points (does the trajectory move along a line only?)");
  // Umeyama: R = U S V^T, S flips the weakest axis when U V^T would be a reflection.
  const Mat3& U = svd.matrixU();
  const Mat3& V = svd.matrixV();
  Mat3 S = Mat3::Identity();
  if (U.determinant() * V.determinant() < 0) S(2, 2) = -1;
  const Mat3 R = U * S * V.transpose();
  const Vec3 t = c.mean_gt - R * c.mean_est;
  return SE3(R, t);
}

bool alignmentIsUnique(const std::vector<Vec3>& est_points, const std::vector<Vec3>& gt_points) {
  const CrossCovariance c = crossCovariance(est_points, gt_points);
  const Eigen::JacobiSVD<Mat3> svd(c.sigma);
  return hasFullRankRotationInfo(svd.singularValues());
}

}  // namespace desslam::eval
