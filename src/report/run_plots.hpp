// The pictures of a run, made from what it wrote (report.json, the main map's trajectory) and the
// sequence's ground truth: trajectory against ground truth (aligned as for the ATE, top and side
// view), ATE per frame with tracking events, RPE over time, features removed by each dynamic
// stage with the mask age, and the time of each stage per frame. SVG, drawn by plot/svg.hpp.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/trajectory.hpp"

namespace desslam::report {

struct RunPlot {
  std::string id;       // figure id and file stem: "ate_over_time" is saved as ate_over_time.svg
  std::string title;
  std::string caption;  // what it shows and how to read it (the HTML page prints it)
  std::string svg;
  std::string fileName() const { return id + ".svg"; }
};

struct LeftOutPlot {
  std::string id;
  std::string reason;
};

struct RunPlots {
  std::vector<RunPlot> plots;         // in page order
  std::vector<LeftOutPlot> left_out;  // plots that could not be made, and why
};

// Every plot's id, in page order (a run with ground truth gets all of them).
const std::vector<std::string>& runPlotIds();

// Events of the tracking, from statistics.per_frame[] and statistics.atlas (timestamps, seconds):
// a loss is a frame not tracked by features after one that was; regained, a frame tracked again
// after such frames without starting a map (relocalisation, or the search around the last pose);
// a new map, a frame that started one (the first included); a merge, the time of the keyframe
// whose recognition merged a map into another.
struct RunEvents {
  std::vector<double> losses, regained, new_maps, merges;
};
RunEvents runEvents(const nlohmann::json& report);

// ground_truth may be null (no_ground_truth_reason then says why): the plots that need it are
// left out. Never throws for odd report contents (missing fields are left out of the plots).
RunPlots makeRunPlots(const nlohmann::json& report, const Trajectory& trajectory, const Trajectory* ground_truth,
                      const std::string& no_ground_truth_reason);

// Writes each plot into dir (atomically) and returns the files. Throws OutputError.
std::vector<std::filesystem::path> writeRunPlots(const std::filesystem::path& dir, const RunPlots& plots);

// For report.json: the files written and the plots left out with their reasons.
nlohmann::json toJson(const RunPlots& plots);

}  // namespace desslam::report
