// Closed-form rigid alignment of two point sets (Umeyama 1991 / Horn 1987, without scale:
// RGB-D trajectories are metric).
#pragma once

#include <vector>

#include "core/se3.hpp"
#include "core/types.hpp"

namespace desslam::eval {

enum class DegenerateInput {
  kThrow,        // collinear/coincident points: throw InputError (the alignment is not unique)
  kAnyMinimiser  // return one of the equally good alignments (e.g. a stationary estimate)
};

// T_gt_est minimising sum_i |gt_i - T_gt_est * est_i|^2. Needs point lists of equal size, at
// least 3 points; with kThrow they must not be collinear. Throws InputError otherwise.
SE3 alignRigid(const std::vector<Vec3>& est_points, const std::vector<Vec3>& gt_points,
               DegenerateInput degenerate = DegenerateInput::kThrow);

// Whether the points determine a unique rigid alignment (not all collinear or coincident).
bool alignmentIsUnique(const std::vector<Vec3>& est_points, const std::vector<Vec3>& gt_points);

}  // namespace desslam::eval
