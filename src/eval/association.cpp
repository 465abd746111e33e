#include "eval/association.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>

#include "core/error.hpp"

namespace desslam::eval {
namespace {

// Timestamps are written with at most six decimals and stored as doubles around 1.3e9 s (a
// resolution of ~2.4e-7 s), so differences within a microsecond of max_dt count as equal.
constexpr double kTimeTolerance = 1e-6;

// Indices of the poses to associate, sorted by time; of poses sharing a timestamp only the last
// in file order is kept.
std::vector<std::size_t> usableIndicesByTime(const Trajectory& trajectory) {
  std::vector<std::size_t> order(trajectory.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return trajectory[a].timestamp < trajectory[b].timestamp;
  });
  std::vector<std::size_t> usable;
  usable.reserve(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (!std::isfinite(trajectory[order[k]].timestamp)) continue;
    const bool repeated_later =
        k + 1 < order.size() && trajectory[order[k + 1]].timestamp == trajectory[order[k]].timestamp;
    if (!repeated_later) usable.push_back(order[k]);
  }
  return usable;
}

struct Candidate {
  double dt;
  std::size_t est_index;
  std::size_t gt_index;
};

}  // namespace

std::vector<Match> associate(const Trajectory& gt, const Trajectory& est, double max_dt) {
  if (!std::isfinite(max_dt) || max_dt < 0)
    throw InputError("max_dt = " + std::to_string(max_dt) + ": must be a finite number of seconds >= 0");

  const std::vector<std::size_t> gt_order = usableIndicesByTime(gt);
  const std::vector<std::size_t> est_order = usableIndicesByTime(est);
  const double window = max_dt + kTimeTolerance;

  // Candidates from a sliding window over the sorted ground truth: O((n + m) log + pairs)
  // instead of the all-pairs loop of associate.py, same result.
  std::vector<Candidate> candidates;
  std::size_t first_gt = 0;
  for (const std::size_t e : est_order) {
    const double t_est = est[e].timestamp;
    while (first_gt < gt_order.size() && gt[gt_order[first_gt]].timestamp < t_est - window) ++first_gt;
    for (std::size_t k = first_gt; k < gt_order.size(); ++k) {
      const double dt = std::abs(gt[gt_order[k]].timestamp - t_est);
      if (gt[gt_order[k]].timestamp > t_est + window) break;
      if (dt <= window) candidates.push_back({dt, e, gt_order[k]});
    }
  }
  // Ties broken by index so the result never depends on the sort implementation.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.dt, a.est_index, a.gt_index) < std::tie(b.dt, b.est_index, b.gt_index);
  });

  std::vector<bool> gt_used(gt.size(), false), est_used(est.size(), false);
  std::vector<Match> matches;
  for (const Candidate& c : candidates) {
    if (gt_used[c.gt_index] || est_used[c.est_index]) continue;
    gt_used[c.gt_index] = est_used[c.est_index] = true;
    matches.push_back({c.gt_index, c.est_index});
  }
  std::sort(matches.begin(), matches.end(), [&](const Match& a, const Match& b) {
    return std::tie(est[a.est_index].timestamp, a.est_index) < std::tie(est[b.est_index].timestamp, b.est_index);
  });
  return matches;
}

}  // namespace desslam::eval
