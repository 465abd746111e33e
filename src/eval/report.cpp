#include "eval/report.hpp"

#include <cstdio>

namespace desslam::eval {

nlohmann::json toJson(const ErrorStats& s) {
  return {{"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median}, {"std", s.std},
          {"min", s.min},   {"max", s.max},   {"count", s.count}};
}

nlohmann::json toJson(const AteResult& ate) {
  const Quat& q = ate.T_gt_est.quaternion();
  const Vec3& t = ate.T_gt_est.translation();
  return {{"translation_m", toJson(ate.translation_m)},
          {"matched", ate.matched},
          {"gt_poses", ate.gt_poses},
          {"est_poses", ate.est_poses},
          {"alignment_unique", ate.alignment_unique},
          {"T_gt_est", {{"translation", {t.x(), t.y(), t.z()}}, {"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}}}}};
}

nlohmann::json toJson(const RpeResult& rpe) {
  return {{"translation_m", toJson(rpe.translation_m)},
          {"rotation_deg", toJson(rpe.rotation_deg)},
          {"delta_s", rpe.delta_s},
          {"pairs", rpe.pairs}};
}

namespace {

std::string row(const char* label, const ErrorStats& s) {
  char line[160];
  std::snprintf(line, sizeof line, "%-16s %10.6f %10.6f %10.6f %10.6f %10.6f\n", label, s.rmse, s.mean, s.median,
                s.std, s.max);
  return line;
}

}  // namespace

std::string formatTable(const AteResult& ate, const RpeResult& rpe, double max_dt) {
  char line[256];
  std::string out;
  std::snprintf(line, sizeof line, "%-16s %10s %10s %10s %10s %10s\n", "", "rmse", "mean", "median", "std", "max");
  out += line;
  out += row("ATE [m]", ate.translation_m);
  if (rpe.pairs > 0) {
    out += row("RPE [m/delta]", rpe.translation_m);
    out += row("RPE [deg/delta]", rpe.rotation_deg);
  } else {
    out += "RPE              n/a (the trajectory is shorter than delta)\n";
  }
  std::snprintf(line, sizeof line,
                "matched %zu of %zu estimate poses (ground truth: %zu poses, max_dt %.3f s); "
                "RPE: %zu pairs, delta %.3f s\n",
                ate.matched, ate.est_poses, ate.gt_poses, max_dt, rpe.pairs, rpe.delta_s);
  out += line;
  if (!ate.alignment_unique)
    out += "note: the estimate is stationary or moves along a line; the alignment is one of many equally good ones\n";
  return out;
}

}  // namespace desslam::eval
