// TUM trajectory files: "timestamp tx ty tz qx qy qz qw" per line, '#' comments,
// world-from-camera poses. Read by TUM's evaluate_ate.py and evo.
#pragma once

#include <filesystem>

#include "core/trajectory.hpp"

namespace desslam::io {

// Throws InputError naming the file (and line) when it is missing or malformed.
Trajectory readTumTrajectory(const std::filesystem::path& path);
// Six decimals for timestamps (as the datasets write them), nine for pose values. Written
// atomically (core/atomic_file.hpp); throws OutputError naming the file and the reason.
void writeTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory);
// CameraTrajectory_all.txt: every frame of every map, "timestamp tx ty tz qx qy qz qw map
// world_map" (TUM's eight columns, then the map the frame was tracked in and the map whose world
// the pose is in). TUM tools that read the first eight columns read it as one trajectory, which it
// is only where world_map is the same.
void writeAtlasTrajectory(const std::filesystem::path& path, const AtlasTrajectory& trajectory);

}  // namespace desslam::io
