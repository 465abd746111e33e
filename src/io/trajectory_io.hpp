// TUM trajectory files: "timestamp tx ty tz qx qy qz qw" per line, '#' comments,
// world-from-camera poses. Read by TUM's evaluate_ate.py and evo.
#pragma once

#include <filesystem>
#include <istream>
#include <string>
#include <vector>

#include "core/trajectory.hpp"

namespace desslam::io {

// Throws InputError naming the file (and line) when it is missing or malformed: fewer than 8
// numbers, a non-finite value (nan, inf) or a position beyond 1e6 m, a zero quaternion. Poses
// with the same timestamp as an earlier one (ties) are kept and reported in `warnings` (when
// given), naming the file and both lines.
Trajectory readTumTrajectory(const std::filesystem::path& path, std::vector<std::string>* warnings = nullptr);
// The same for text in memory; `name` names it in messages.
Trajectory parseTumTrajectory(std::istream& in, const std::string& name, std::vector<std::string>* warnings = nullptr);
// Six decimals for timestamps (as the datasets write them), nine for pose values. Written
// atomically (core/atomic_file.hpp); throws OutputError naming the file and the reason.
void writeTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory);
// CameraTrajectory_all.txt: every frame of every map, "timestamp tx ty tz qx qy qz qw map
// world_map" (TUM's eight columns, then the map the frame was tracked in and the map whose world
// the pose is in). TUM tools that read the first eight columns read it as one trajectory, which it
// is only where world_map is the same.
void writeAtlasTrajectory(const std::filesystem::path& path, const AtlasTrajectory& trajectory);
// Reads that format back: every data line needs the ten columns (the pose as readTumTrajectory
// checks it, then two integers); throws InputError naming the file and line otherwise.
AtlasTrajectory readAtlasTrajectory(const std::filesystem::path& path);
AtlasTrajectory parseAtlasTrajectory(std::istream& in, const std::string& name);
// Whether the first data line of the file has the ten columns of CameraTrajectory_all.txt (false
// for a TUM file, and for a file that cannot be read: readTumTrajectory then names the problem).
bool hasAtlasColumns(const std::filesystem::path& path);

}  // namespace desslam::io
