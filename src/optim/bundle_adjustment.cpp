#include "optim/bundle_adjustment.hpp"

#include <cmath>
#include <memory>
#include <string>

#include <ceres/ceres.h>

#include "core/error.hpp"
#include "optim/reprojection_cost.hpp"

namespace desslam::optim {

void BundleAdjustmentOptions::validate() const {
  const char* s = kSection;
  requireThat(bf > 0, s, "bf", "must be positive (fx times the virtual baseline, pixel*metres; ~40 for TUM)");
  requireInRange(s, "iterations", iterations, 1, 1000);
  requireThat(chi2_mono > 0, s, "chi2_mono", "must be positive (5.991 = 95% for 2 dof)");
  requireThat(chi2_rgbd > 0, s, "chi2_rgbd", "must be positive (7.815 = 95% for 3 dof)");
  requireInRange(s, "threads", threads, 1, 256);
}

namespace {

// Stops the solve when the caller raises the flag. TERMINATE_SUCCESSFULLY (not ABORT) so Ceres
// still writes back the last accepted estimate, which is better than the start.
class AbortCallback final : public ceres::IterationCallback {
 public:
  explicit AbortCallback(const std::atomic<bool>* abort) : abort_(abort) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& /*summary*/) override {
    if (abort_ != nullptr && abort_->load(std::memory_order_relaxed)) {
      aborted_ = true;
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return ceres::SOLVER_CONTINUE;
  }
  bool aborted() const { return aborted_; }

 private:
  const std::atomic<bool>* abort_;
  bool aborted_ = false;
};

// Points are eliminated first (Schur complement); the reduced system holds only the poses. For
// local BA (tens of keyframes) it is small enough that a dense factorisation is cheapest; larger
// ones (global BA) use sparse Cholesky when Ceres has a sparse backend (Debian's has SuiteSparse).
void chooseLinearSolver(ceres::Solver::Options& o, int variable_poses) {
  constexpr int kMaxPosesForDenseSchur = 40;
  o.linear_solver_type = ceres::DENSE_SCHUR;
  if (variable_poses <= kMaxPosesForDenseSchur) return;
  if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)) {
    o.linear_solver_type = ceres::SPARSE_SCHUR;
    o.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  } else if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)) {
    o.linear_solver_type = ceres::SPARSE_SCHUR;
    o.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
  }
}

ceres::Solver::Options baSolverOptions(const BundleAdjustmentOptions& options) {
  ceres::Solver::Options o;
  o.max_num_iterations = options.iterations;
  o.num_threads = options.threads;
  o.logging_type = ceres::SILENT;
  o.minimizer_progress_to_stdout = false;
  return o;
}

void requireValidInput(const std::vector<BaKeyframe>& keyframes, const std::vector<BaPoint>& points,
                       const std::vector<BaObservation>& observations) {
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const BaObservation& o = observations[i];
    const std::string where = "bundleAdjust: observation " + std::to_string(i);
    if (o.keyframe < 0 || o.keyframe >= static_cast<int>(keyframes.size()))
      throw InputError(where + " refers to keyframe " + std::to_string(o.keyframe) + " but there are " +
                       std::to_string(keyframes.size()) + " keyframes; indices must be in [0, size)");
    if (o.point < 0 || o.point >= static_cast<int>(points.size()))
      throw InputError(where + " refers to point " + std::to_string(o.point) + " but there are " +
                       std::to_string(points.size()) + " points; indices must be in [0, size)");
    if (!(o.obs.inv_sigma2 > 0) || !std::isfinite(o.obs.inv_sigma2))
      throw InputError(where + " has inv_sigma2 = " + std::to_string(o.obs.inv_sigma2) +
                       "; it must be a positive finite 1/sigma^2 of the keypoint's pyramid level");
  }
}

}  // namespace

bool bundleAdjust(const PinholeCamera& camera, std::vector<BaKeyframe>& keyframes, std::vector<BaPoint>& points,
                  std::vector<BaObservation>& observations, const BundleAdjustmentOptions& options,
                  const std::atomic<bool>* abort) {
  options.validate();
  requireValidInput(keyframes, points, observations);
  if (abort != nullptr && abort->load()) return false;

  const auto K = detail::StereoIntrinsics::from(camera, options.bf);
  // Working copies the solver edits; written back to the caller's vectors at the end.
  std::vector<detail::PoseBlock> poses;
  poses.reserve(keyframes.size());
  for (const auto& kf : keyframes) poses.push_back(detail::toPoseBlock(kf.T_c_w));
  std::vector<Vec3> positions;
  positions.reserve(points.size());
  for (const auto& p : points) positions.push_back(p.p_w);

  auto chi2Of = [&](const BaObservation& o) {
    const SE3 T_c_w = detail::fromPoseBlock(poses[o.keyframe].data());
    return detail::chi2(K, T_c_w * positions[o.point], o.obs);
  };
  auto classify = [&] {
    for (auto& o : observations) {
      const double threshold = o.obs.hasDepth() ? options.chi2_rgbd : options.chi2_mono;
      o.outlier = !(chi2Of(o) <= threshold);
    }
  };

  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  costs.reserve(observations.size());
  for (auto& o : observations) {
    costs.emplace_back(detail::makePosePointCost(K, o.obs));
    // Pass 1 uses everything that projects; points behind a camera would fail evaluation.
    o.outlier = !std::isfinite(chi2Of(o));
  }

  ceres::HuberLoss huber_mono(std::sqrt(options.chi2_mono));
  ceres::HuberLoss huber_rgbd(std::sqrt(options.chi2_rgbd));
  detail::Se3LeftManifold manifold;
  AbortCallback callback(abort);
  ceres::Solver::Options solver_options = baSolverOptions(options);
  solver_options.callbacks.push_back(&callback);

  auto runPass = [&](bool robust) {
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.disable_all_safety_checks = true;  // blocks are added once each, by construction
    ceres::Problem problem(problem_options);
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    std::vector<char> pose_added(keyframes.size(), 0), point_added(points.size(), 0);
    int variable_poses = 0;
    for (std::size_t i = 0; i < observations.size(); ++i) {
      const BaObservation& o = observations[i];
      if (o.outlier) continue;
      double* pose = poses[o.keyframe].data();
      double* point = positions[o.point].data();
      if (!pose_added[o.keyframe]) {
        problem.AddParameterBlock(pose, detail::kPoseAmbientSize, &manifold);
        if (keyframes[o.keyframe].fixed) problem.SetParameterBlockConstant(pose);
        ordering->AddElementToGroup(pose, 1);
        pose_added[o.keyframe] = 1;
        if (!keyframes[o.keyframe].fixed) ++variable_poses;
      }
      if (!point_added[o.point]) {
        problem.AddParameterBlock(point, 3);
        ordering->AddElementToGroup(point, 0);
        point_added[o.point] = 1;
      }
      ceres::LossFunction* loss = nullptr;
      if (robust) loss = o.obs.hasDepth() ? &huber_rgbd : &huber_mono;
      problem.AddResidualBlock(costs[i].get(), loss, pose, point);
    }
    if (problem.NumResidualBlocks() == 0) return;
    solver_options.linear_solver_ordering = ordering;
    chooseLinearSolver(solver_options, variable_poses);
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
  };

  runPass(/*robust=*/true);
  if (options.second_pass_without_outliers && !callback.aborted()) {
    classify();
    runPass(/*robust=*/false);
  }
  classify();

  for (std::size_t k = 0; k < keyframes.size(); ++k)
    if (!keyframes[k].fixed) keyframes[k].T_c_w = detail::fromPoseBlock(poses[k].data());
  for (std::size_t p = 0; p < points.size(); ++p) points[p].p_w = positions[p];
  return !callback.aborted();
}

}  // namespace desslam::optim
