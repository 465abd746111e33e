// Pairing estimate poses with ground-truth poses by timestamp (TUM associate.py semantics).
#pragma once

#include <cstddef>
#include <vector>

#include "core/trajectory.hpp"

namespace desslam::eval {

// One associated pair: indices into the ground-truth and estimate trajectories as given.
struct Match {
  std::size_t gt_index = 0;
  std::size_t est_index = 0;
};

// Candidate pairs with |t_gt - t_est| <= max_dt (seconds) are taken greedily, smallest time
// difference first; each timestamp is used at most once. Where a trajectory repeats a
// timestamp, its last pose with that timestamp is the one used (associate.py reads files into a
// dict). Inputs need not be sorted; the result is sorted by estimate time.
// Throws InputError when max_dt is negative or not finite.
std::vector<Match> associate(const Trajectory& gt, const Trajectory& est, double max_dt = 0.02);

}  // namespace desslam::eval
