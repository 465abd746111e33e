// TUM trajectory files: "timestamp tx ty tz qx qy qz qw" per line, '#' comments,
// world-from-camera poses. Read by TUM's evaluate_ate.py and evo.
#pragma once

#include <filesystem>

#include "core/trajectory.hpp"

namespace desslam::io {

// Throws InputError naming the file (and line) when it is missing or malformed.
Trajectory readTumTrajectory(const std::filesystem::path& path);
// Six decimals for timestamps (as the datasets write them), nine for pose values.
void writeTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory);

}  // namespace desslam::io
