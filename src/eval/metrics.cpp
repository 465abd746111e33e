#include "eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <string>

#include "core/error.hpp"
#include "eval/alignment.hpp"
#include "eval/association.hpp"

namespace desslam::eval {
namespace {

std::string poseCount(std::size_t n) { return std::to_string(n) + (n == 1 ? " pose" : " poses"); }

// Why fewer than `needed` poses could be compared: a trajectory with too few poses at all, or
// poses whose timestamps did not associate (`metric`: "ATE" or "RPE").
std::string tooFewMatchesMessage(const char* metric, std::size_t matched, std::size_t needed, const Trajectory& gt,
                                 const Trajectory& est, double max_dt) {
  const std::string at_least = std::string(metric) + " needs at least " + std::to_string(needed);
  if (est.size() < needed)
    return "the estimate has " + poseCount(est.size()) + ", too few: " + at_least +
           " (a run that tracked fewer frames, or the wrong file?)";
  if (gt.size() < needed)
    return "the ground truth has " + poseCount(gt.size()) + ", too few: " + at_least + " (the wrong file?)";
  return "no timestamps within max_dt: are these the same sequence? (" + std::to_string(matched) + " of " +
         std::to_string(est.size()) + " estimate poses have a ground-truth pose (of " + std::to_string(gt.size()) +
         ") within max_dt = " + std::to_string(max_dt) + " s; need " + std::to_string(needed) +
         "; check both files use the same clock, or raise --max-dt)";
}

}  // namespace

ErrorStats summarize(std::vector<double> errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) return s;
  const double n = static_cast<double>(errors.size());
  double sum = 0, sum_sq = 0;
  for (const double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double sum_dev_sq = 0;  // two-pass variance: no cancellation when errors are large and close
  for (const double e : errors) sum_dev_sq += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(sum_dev_sq / n);
  std::sort(errors.begin(), errors.end());
  s.min = errors.front();
  s.max = errors.back();
  const std::size_t mid = errors.size() / 2;
  s.median = errors.size() % 2 == 1 ? errors[mid] : 0.5 * (errors[mid - 1] + errors[mid]);
  return s;
}

AteResult computeAte(const Trajectory& gt, const Trajectory& est, double max_dt) {
  const std::vector<Match> matches = associate(gt, est, max_dt);
  if (matches.size() < 3) throw InputError(tooFewMatchesMessage("ATE", matches.size(), 3, gt, est, max_dt));

  std::vector<Vec3> est_points, gt_points;
  est_points.reserve(matches.size());
  gt_points.reserve(matches.size());
  for (const Match& m : matches) {
    est_points.push_back(est[m.est_index].T_w_c.translation());
    gt_points.push_back(gt[m.gt_index].T_w_c.translation());
  }
  AteResult result;
  result.matched = matches.size();
  result.gt_poses = gt.size();
  result.est_poses = est.size();
  // A failed run may leave a stationary or straight-line estimate: its ATE is still well
  // defined (every optimal alignment gives the same errors), so report it instead of throwing.
  result.alignment_unique = alignmentIsUnique(est_points, gt_points);
  result.T_gt_est = alignRigid(est_points, gt_points, DegenerateInput::kAnyMinimiser);

  std::vector<double> errors;
  errors.reserve(matches.size());
  result.per_pose.reserve(matches.size());
  for (std::size_t i = 0; i < matches.size(); ++i) {
    errors.push_back((gt_points[i] - result.T_gt_est * est_points[i]).norm());
    result.per_pose.push_back({est[matches[i].est_index].timestamp, errors.back(), matches[i].gt_index,
                               matches[i].est_index});
  }
  result.translation_m = summarize(std::move(errors));
  return result;
}

AtlasAteResult computeAtlasAte(const Trajectory& gt, const AtlasTrajectory& est, double max_dt) {
  std::map<int, Trajectory> by_world;
  for (const AtlasPose& p : est) by_world[p.world_map].push_back({p.timestamp, p.T_w_c});
  AtlasAteResult result;
  std::vector<double> errors;
  for (const auto& [world_map, trajectory] : by_world) {
    MapAte map_ate{world_map, trajectory.size(), std::nullopt};
    if (associate(gt, trajectory, max_dt).size() >= 3) {
      map_ate.ate = computeAte(gt, trajectory, max_dt);
      for (const PoseError& e : map_ate.ate->per_pose) errors.push_back(e.error_m);
    }
    result.maps.push_back(std::move(map_ate));
  }
  if (errors.empty())
    throw InputError("no map of the estimate has 3 poses within max_dt = " + std::to_string(max_dt) +
                     " s of a ground-truth pose (" + poseCount(est.size()) + " in " + std::to_string(by_world.size()) +
                     (by_world.size() == 1 ? " map" : " maps") +
                     "): ATE aligns each map on its own and needs at least 3 in one (the same sequence?)");
  result.all_maps_m = summarize(std::move(errors));
  return result;
}

RpeResult computeRpe(const Trajectory& gt, const Trajectory& est, double delta_s, double max_dt) {
  if (!std::isfinite(delta_s) || delta_s <= 0)
    throw InputError("delta = " + std::to_string(delta_s) + ": the RPE window must be a positive number of seconds");
  const std::vector<Match> matches = associate(gt, est, max_dt);
  if (matches.size() < 2) throw InputError(tooFewMatchesMessage("RPE", matches.size(), 2, gt, est, max_dt));

  std::vector<double> times;  // associated estimate times, ascending (associate sorts by them)
  times.reserve(matches.size());
  for (const Match& m : matches) times.push_back(est[m.est_index].timestamp);

  std::vector<double> translation_errors, rotation_errors;
  std::vector<RpePair> per_pair;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    const double target = times[i] + delta_s;
    if (target > times.back() + max_dt) break;  // the window would run past the trajectory's end
    // Closest associated time to the target (ties go to the earlier pose).
    std::size_t j = static_cast<std::size_t>(std::lower_bound(times.begin(), times.end(), target) - times.begin());
    if (j == times.size() || (j > 0 && target - times[j - 1] <= times[j] - target)) --j;
    if (j <= i) continue;  // delta shorter than the frame spacing: no later pose to compare with

    const SE3& gt_i = gt[matches[i].gt_index].T_w_c;
    const SE3& gt_j = gt[matches[j].gt_index].T_w_c;
    const SE3& est_i = est[matches[i].est_index].T_w_c;
    const SE3& est_j = est[matches[j].est_index].T_w_c;
    const SE3 error = (gt_i.inverse() * gt_j).inverse() * (est_i.inverse() * est_j);
    translation_errors.push_back(error.translation().norm());
    rotation_errors.push_back(error.rotationAngle() * 180.0 / std::numbers::pi);
    per_pair.push_back({times[i], times[j], translation_errors.back(), rotation_errors.back()});
  }
  RpeResult result;
  result.delta_s = delta_s;
  result.pairs = translation_errors.size();
  result.translation_m = summarize(std::move(translation_errors));
  result.rotation_deg = summarize(std::move(rotation_errors));
  result.per_pair = std::move(per_pair);
  return result;
}

}  // namespace desslam::eval
