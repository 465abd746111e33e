// A `desslam run` output folder, read back: report.json, the main map's trajectory and the
// sequence's ground truth (from the path report.json names, or a file given instead).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/trajectory.hpp"

namespace desslam::report {

struct RunFolder {
  std::filesystem::path dir;
  nlohmann::json report;                   // report.json
  Trajectory trajectory;                   // CameraTrajectory.txt (empty when missing: see notes)
  std::optional<Trajectory> ground_truth;  // none: no_ground_truth_reason says why
  std::filesystem::path ground_truth_file;
  std::string no_ground_truth_reason;
  std::vector<std::string> notes;          // outputs missing from the folder
};

// Throws InputError naming the file and what to do when `dir` is not a run folder, report.json is
// missing, not JSON or not a run report, CameraTrajectory.txt is malformed, or `ground_truth`
// (when given) cannot be read. A missing or broken groundtruth.txt of the sequence is no error:
// the report goes without the plots that need it and says why.
RunFolder loadRunFolder(const std::filesystem::path& dir, const std::filesystem::path& ground_truth = {});

}  // namespace desslam::report
