#include "report/run_folder.hpp"

#include <fstream>
#include <iterator>

#include "core/error.hpp"
#include "io/trajectory_io.hpp"

namespace desslam::report {
namespace fs = std::filesystem;

RunFolder loadRunFolder(const fs::path& dir, const fs::path& ground_truth) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError(dir.string() + ": no such folder: give the --out folder of a `desslam run`");
  RunFolder run;
  run.dir = dir;
  const fs::path report_file = dir / "report.json";
  if (!fs::is_regular_file(report_file, ec))
    throw InputError(report_file.string() + " not found: " + dir.string() +
                     " is not the output folder of a `desslam run` (run one with --out " + dir.string() + ")");
  std::ifstream in(report_file, std::ios::binary);
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (!in.good() && !in.eof()) throw InputError(report_file.string() + ": cannot be read");
  try {
    run.report = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(report_file.string() + " is not valid JSON (" + e.what() +
                     "): was the run killed while writing it? Run `desslam run` again with --overwrite");
  }
  if (!run.report.is_object() || !run.report.contains("statistics") || !run.report["statistics"].is_object() ||
      !run.report["statistics"].contains("per_frame") || !run.report["statistics"]["per_frame"].is_array())
    throw InputError(report_file.string() +
                     " is not a `desslam run` report (no statistics.per_frame): give the --out folder of a run");

  if (const fs::path file = dir / "CameraTrajectory.txt"; fs::is_regular_file(file, ec))
    run.trajectory = io::readTumTrajectory(file);
  else
    run.notes.push_back(file.string() + " is missing: no trajectory plots");

  if (!ground_truth.empty()) {
    run.ground_truth_file = ground_truth;
    if (!fs::is_regular_file(ground_truth, ec))
      throw InputError(ground_truth.string() + " not found: give the sequence's groundtruth.txt (TUM format)");
    run.ground_truth = io::readTumTrajectory(ground_truth);
    if (run.ground_truth->empty()) throw InputError(ground_truth.string() + " holds no poses");
    return run;
  }
  const nlohmann::json& sequence = run.report["sequence"];
  if (!sequence.is_string()) {
    run.no_ground_truth_reason = "report.json names no sequence folder (pass --groundtruth FILE)";
    return run;
  }
  run.ground_truth_file = fs::path(sequence.get<std::string>()) / "groundtruth.txt";
  if (!fs::is_regular_file(run.ground_truth_file, ec)) {
    run.no_ground_truth_reason = run.ground_truth_file.string() +
                                 " does not exist (the sequence has no ground truth, or it moved: pass --groundtruth FILE)";
    return run;
  }
  try {
    Trajectory gt = io::readTumTrajectory(run.ground_truth_file);
    if (gt.empty())
      run.no_ground_truth_reason = run.ground_truth_file.string() + " holds no poses";
    else
      run.ground_truth = std::move(gt);
  } catch (const InputError& e) {
    run.no_ground_truth_reason = e.what();
  }
  return run;
}

}  // namespace desslam::report
