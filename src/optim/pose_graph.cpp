#include "optim/pose_graph.hpp"

#include <array>
#include <cmath>
#include <string>

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include "core/error.hpp"
#include "core/option_fields.hpp"

namespace desslam::optim {

namespace {

// Relative-pose residual between two world-from-camera nodes, each held as an Eigen-order
// quaternion block (4) and a translation block (3). Automatic differentiation: the residual is
// cheap and the graph small, so hand-written Jacobians would buy nothing.
class RelativePoseError {
 public:
  RelativePoseError(const SE3& T_from_to, double sqrt_weight, double sqrt_rotation_weight)
      : q_m_inv_(T_from_to.quaternion().conjugate()),
        t_m_(T_from_to.translation()),
        R_m_inv_(T_from_to.rotation().transpose()),
        sqrt_weight_(sqrt_weight),
        sqrt_rotation_weight_(sqrt_rotation_weight) {}

  template <class T>
  bool operator()(const T* q_a_ptr, const T* t_a_ptr, const T* q_b_ptr, const T* t_b_ptr, T* residual_ptr) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(q_a_ptr), q_b(q_b_ptr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_a(t_a_ptr), t_b(t_b_ptr);
    // Estimated T_a_b = T_w_a^-1 * T_w_b.
    const Eigen::Quaternion<T> q_a_inv = q_a.conjugate();
    const Eigen::Quaternion<T> q_ab = q_a_inv * q_b;
    const Eigen::Matrix<T, 3, 1> t_ab = q_a_inv * (t_b - t_a);
    // Error transform T_m^-1 * T_est: its translation and twice its quaternion's vector part
    // (~ the rotation vector for small errors).
    const Eigen::Quaternion<T> q_err = q_m_inv_.template cast<T>() * q_ab;
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual_ptr);
    r.template head<3>() = T(sqrt_weight_) * (R_m_inv_.template cast<T>() * (t_ab - t_m_.template cast<T>()));
    r.template tail<3>() = T(2.0 * sqrt_weight_ * sqrt_rotation_weight_) * q_err.vec();
    return true;
  }

 private:
  Quat q_m_inv_;
  Vec3 t_m_;
  Mat3 R_m_inv_;
  double sqrt_weight_;
  double sqrt_rotation_weight_;
};

}  // namespace

void PoseGraphOptions::validate() const {
  requireInRange("pose_graph", "iterations", iterations, 1, 10000);
  requireInRange("pose_graph", "rotation_weight", rotation_weight, 1e-9, 1e9);
  requireInRange("pose_graph", "threads", threads, 1, 256);
}

PoseGraphSummary optimizePoseGraph(std::vector<PoseGraphNode>& nodes, const std::vector<PoseGraphEdge>& edges,
                                   const PoseGraphOptions& options) {
  options.validate();
  PoseGraphSummary summary;
  const int n = static_cast<int>(nodes.size());
  for (size_t e = 0; e < edges.size(); ++e) {
    const PoseGraphEdge& edge = edges[e];
    if (edge.from < 0 || edge.from >= n || edge.to < 0 || edge.to >= n || edge.from == edge.to)
      throw InputError("pose graph edge " + std::to_string(e) + " (" + std::to_string(edge.from) + " -> " +
                       std::to_string(edge.to) + ") needs two different node indices below " + std::to_string(n));
    if (!(edge.weight > 0) || !std::isfinite(edge.weight))
      throw InputError("pose graph edge " + std::to_string(e) + " has weight " + std::to_string(edge.weight) +
                       ": weights must be positive and finite");
  }
  if (nodes.empty() || edges.empty()) return summary;

  std::vector<std::array<double, 4>> rotations(nodes.size());
  std::vector<std::array<double, 3>> translations(nodes.size());
  for (int i = 0; i < n; ++i) {
    const Quat& q = nodes[i].T_w_c.quaternion();
    rotations[i] = {q.x(), q.y(), q.z(), q.w()};
    const Vec3& t = nodes[i].T_w_c.translation();
    translations[i] = {t.x(), t.y(), t.z()};
  }

  ceres::Problem problem;
  const double sqrt_rotation_weight = std::sqrt(options.rotation_weight);
  for (const PoseGraphEdge& edge : edges) {
    auto* cost = new ceres::AutoDiffCostFunction<RelativePoseError, 6, 4, 3, 4, 3>(
        new RelativePoseError(edge.T_from_to, std::sqrt(edge.weight), sqrt_rotation_weight));
    problem.AddResidualBlock(cost, nullptr, rotations[edge.from].data(), translations[edge.from].data(),
                             rotations[edge.to].data(), translations[edge.to].data());
  }
  bool any_fixed = false;
  for (int i = 0; i < n; ++i) {
    if (!problem.HasParameterBlock(rotations[i].data())) continue;  // node without edges
    problem.SetManifold(rotations[i].data(), new ceres::EigenQuaternionManifold());
    if (nodes[i].fixed) {
      problem.SetParameterBlockConstant(rotations[i].data());
      problem.SetParameterBlockConstant(translations[i].data());
      any_fixed = true;
    }
  }
  if (!any_fixed) {
    for (int i = 0; i < n; ++i) {
      if (!problem.HasParameterBlock(rotations[i].data())) continue;
      problem.SetParameterBlockConstant(rotations[i].data());
      problem.SetParameterBlockConstant(translations[i].data());
      break;
    }
  }

  ceres::Solver::Options solver;
  // A loop's graph is sparse (a chain plus a few covisibility and loop edges).
  solver.linear_solver_type = ceres::DENSE_QR;
  if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)) {
    solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  } else if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)) {
    solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver.sparse_linear_algebra_library_type = ceres::EIGEN_SPARSE;
  }
  solver.max_num_iterations = options.iterations;
  solver.num_threads = options.threads;
  solver.logging_type = ceres::SILENT;
  solver.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary result;
  ceres::Solve(solver, &problem, &result);

  summary.initial_cost = result.initial_cost;
  summary.final_cost = result.final_cost;
  summary.iterations = static_cast<int>(result.iterations.size());
  summary.usable = result.IsSolutionUsable();
  if (!summary.usable) return summary;
  for (int i = 0; i < n; ++i) {
    if (nodes[i].fixed) continue;
    const auto& q = rotations[i];
    const auto& t = translations[i];
    nodes[i].T_w_c = SE3(Quat(q[3], q[0], q[1], q[2]), Vec3(t[0], t[1], t[2]));
  }
  return summary;
}

}  // namespace desslam::optim
