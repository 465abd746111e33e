#include "io/rgbd_sequence.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>

#include <spdlog/spdlog.h>

#include "core/error.hpp"
#include "io/trajectory_io.hpp"

namespace desslam::io {

std::vector<StreamPair> associateByTime(const std::vector<Timestamp>& rgb, const std::vector<Timestamp>& depth,
                                        double max_dt) {
  // Depth in time order, so that only the window around each RGB timestamp is scanned.
  std::vector<std::size_t> depth_order(depth.size());
  std::iota(depth_order.begin(), depth_order.end(), std::size_t{0});
  std::stable_sort(depth_order.begin(), depth_order.end(),
                   [&](std::size_t a, std::size_t b) { return depth[a] < depth[b]; });
  constexpr double kDecimalSlack = 1e-9;  // "within 0.02 s" holds for 1.00 vs 1.02 despite rounding
  const double limit = max_dt + kDecimalSlack;
  struct Candidate {
    double abs_dt;
    std::size_t rgb, depth_rank;  // depth_rank: position in depth_order
  };
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < rgb.size(); ++i) {
    const double t = rgb[i];
    auto it = std::lower_bound(depth_order.begin(), depth_order.end(), t - limit,
                               [&](std::size_t d, double v) { return depth[d] < v; });
    for (; it != depth_order.end() && depth[*it] <= t + limit; ++it)
      candidates.push_back({std::abs(depth[*it] - t), i, static_cast<std::size_t>(it - depth_order.begin())});
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.abs_dt, a.rgb, a.depth_rank) < std::tie(b.abs_dt, b.rgb, b.depth_rank);
  });
  std::vector<bool> rgb_used(rgb.size(), false), depth_used(depth.size(), false);
  std::vector<StreamPair> pairs;
  for (const Candidate& c : candidates) {
    const std::size_t d = depth_order[c.depth_rank];
    if (rgb_used[c.rgb] || depth_used[d]) continue;
    rgb_used[c.rgb] = depth_used[d] = true;
    pairs.push_back({c.rgb, d});
  }
  std::stable_sort(pairs.begin(), pairs.end(), [&](const StreamPair& a, const StreamPair& b) {
    return rgb[a.rgb] < rgb[b.rgb] || (rgb[a.rgb] == rgb[b.rgb] && a.rgb < b.rgb);
  });
  return pairs;
}

OptionalGroundTruth readOptionalGroundTruth(const std::filesystem::path& file, std::vector<std::string>& warnings) {
  OptionalGroundTruth out;
  std::vector<std::string> file_warnings;
  try {
    Trajectory trajectory = readTumTrajectory(file, &file_warnings);
    if (trajectory.empty())
      out.problem = file.string() + " holds no poses";
    else
      out.trajectory = std::move(trajectory);
  } catch (const InputError& e) {
    out.problem = e.what();
  }
  for (std::string& w : file_warnings) {
    spdlog::warn("{}", w);
    warnings.push_back(std::move(w));
  }
  if (!out.problem.empty()) {
    std::string msg = "ignoring the ground truth: " + out.problem +
                      " (the run goes on without ATE/RPE and without the depth-scale check against it)";
    spdlog::warn("{}", msg);
    warnings.push_back(std::move(msg));
  }
  return out;
}

}  // namespace desslam::io
