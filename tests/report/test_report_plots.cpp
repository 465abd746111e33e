// The plots and the page of a run, made in memory from a constructed report.json (known events),
// a trajectory and its ground truth; and the run-folder reader's errors.
#include <cmath>
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "plot/svg.hpp"
#include "report/html_report.hpp"
#include "report/run_folder.hpp"
#include "report/run_plots.hpp"
#include "support/expect_contains.hpp"
#include "support/temp_dir.hpp"
#include "support/xml_check.hpp"

namespace desslam::report {
namespace {

using nlohmann::json;
constexpr double kT0 = 1548339819.87426;
constexpr int kFrames = 90;

double frameTime(int k) { return kT0 + k / 30.0; }

// 90 frames: lost 20-25 (20, 21 predicted), regained at 26 in the same map; lost 38-39, a new
// map (1) from 40 on, merged into map 0 at frame 50's time.
json constructedReport() {
  json frames = json::array();
  for (int k = 0; k < kFrames; ++k) {
    const bool lost = (k >= 20 && k <= 25) || k == 38 || k == 39;
    frames.push_back({{"timestamp", frameTime(k)},
                      {"tracked", !lost},
                      {"predicted", k == 20 || k == 21},
                      {"new_map", k == 0 || k == 40},
                      {"map", lost && k > 21 ? -1 : (k >= 40 ? 1 : 0)},
                      {"features", 1000},
                      {"in_mask", 100 + k},
                      {"semantic_removed", 0},
                      {"stage1_removed", 50 + k % 7},
                      {"free_space_removed", k % 3},
                      {"stage2_removed", k % 5},
                      {"mask_age", k % 10 == 0 ? -1 : k % 3},
                      {"extraction_ms", 12.0 + k % 4},
                      {"pose_tracking_ms", 8.0},
                      {"mask_wait_ms", 3.0},
                      {"segmentation_ms", k % 10 == 0 ? -1.0 : 25.0},
                      {"total_ms", k == 50 ? 900.0 : 30.0}});
  }
  json maps = json::array({{{"id", 0}, {"reason", "first"}, {"merged_into", nullptr}, {"frames", 80}},
                           {{"id", 1}, {"reason", "lost"}, {"merged_into", 0}, {"merged_at", frameTime(50)}, {"frames", 50}}});
  return {{"sequence", "/nonexistent/sequence"},
          {"settings", {{"dynamic", {{"mode", "full"}}}, {"camera", {{"fx", 500.0}}}}},
          {"statistics",
           {{"per_frame", frames},
            {"counts", {{"frames", kFrames}, {"frames_tracked", 82}, {"frames_with_pose", 84}}},
            {"atlas", {{"maps", maps}, {"merges", 1}, {"maps_started", 2}, {"main_map", 0}}}}},
          {"exit_code", 0}};
}

// A camera on a curve (ground truth at 30 Hz over the run) and the estimate: the same poses of
// the frames with a pose, in a rotated and moved world.
Trajectory groundTruth() {
  Trajectory gt;
  for (int k = 0; k < kFrames; ++k) {
    const double s = k / 30.0;
    gt.push_back({frameTime(k), SE3(Quat::Identity(), Vec3(std::cos(s), 0.5 * std::sin(s), 1.5 + 0.05 * s))});
  }
  return gt;
}

Trajectory estimate(const Trajectory& gt) {
  const SE3 T_est_gt(so3Exp(Vec3(0.2, -0.4, 1.0)), Vec3(1, 2, 3));
  Trajectory est;
  for (int k = 0; k < kFrames; ++k)
    if (k < 22 || (k > 25 && k < 38) || k > 39) est.push_back({gt[k].timestamp, T_est_gt * gt[k].T_w_c});
  return est;
}

const RunPlot* find(const RunPlots& plots, const std::string& id) {
  for (const RunPlot& p : plots.plots)
    if (p.id == id) return &p;
  return nullptr;
}

TEST(ReportEvents, LossesRegainsNewMapsAndMergesFromPerFrame) {
  const RunEvents events = runEvents(constructedReport());
  ASSERT_EQ(events.losses.size(), 2u);
  EXPECT_DOUBLE_EQ(events.losses[0], frameTime(20));
  EXPECT_DOUBLE_EQ(events.losses[1], frameTime(38));
  ASSERT_EQ(events.regained.size(), 1u);  // frame 40 started a map: not a regain
  EXPECT_DOUBLE_EQ(events.regained[0], frameTime(26));
  ASSERT_EQ(events.new_maps.size(), 2u);
  EXPECT_DOUBLE_EQ(events.new_maps[1], frameTime(40));
  ASSERT_EQ(events.merges.size(), 1u);
  EXPECT_DOUBLE_EQ(events.merges[0], frameTime(50));
  EXPECT_TRUE(runEvents(json::object()).losses.empty()) << "no per_frame: no events, no throw";
}

TEST(ReportPlots, WithGroundTruthEveryPlotIsMadeAndNamed) {
  const Trajectory gt = groundTruth();
  const RunPlots plots = makeRunPlots(constructedReport(), estimate(gt), &gt, "");
  EXPECT_TRUE(plots.left_out.empty()) << plots.left_out.front().id << ": " << plots.left_out.front().reason;
  ASSERT_EQ(plots.plots.size(), runPlotIds().size());
  for (size_t k = 0; k < plots.plots.size(); ++k) {
    const RunPlot& p = plots.plots[k];
    EXPECT_EQ(p.id, runPlotIds()[k]) << "page order";
    EXPECT_EQ(p.fileName(), p.id + ".svg");
    EXPECT_EQ(test::xmlProblem(p.svg), "") << p.id;
    EXPECT_CONTAINS(p.svg, "id=\"" + p.id + "\"");
    EXPECT_FALSE(p.title.empty());
    EXPECT_FALSE(p.caption.empty());
    EXPECT_EQ(p.svg.find("nan"), std::string::npos) << p.id;
  }
  // The ATE plot: the estimate is an exact rigid copy, so its errors are ~0, and its events carry
  // their counts.
  const RunPlot* ate = find(plots, "ate_over_time");
  ASSERT_NE(ate, nullptr);
  EXPECT_CONTAINS(ate->caption, "RMSE 0.0000 m");
  EXPECT_CONTAINS(ate->svg, "tracking lost (2)");
  EXPECT_CONTAINS(ate->svg, "regained / relocalised (1)");
  EXPECT_CONTAINS(ate->svg, "new map (2)");
  EXPECT_CONTAINS(ate->svg, "maps merged (1)");
  // Top view: the two axes along which the ground truth moved most (x: 1 m, y: 0.5 m; z 0.15 m).
  EXPECT_CONTAINS(find(plots, "trajectory_top")->title, "(x-y)");
  EXPECT_CONTAINS(find(plots, "trajectory_side")->title, "(x-z)");
  // The one slow frame (900 ms) does not flatten the timing plot: the axis is cut and says so.
  EXPECT_CONTAINS(find(plots, "stage_timings")->caption,
                  "whole frame (processFrame): axis cut at 40 ms, 1 values above, up to 900 ms.");
  EXPECT_EQ(find(plots, "stage_timings")->caption.find("ORB extraction: axis cut"), std::string::npos);
  // Mask removals never happened (full mode): not in the legend; stage 1 and 2 are.
  const std::string& dynamic = find(plots, "dynamic_features")->svg;
  EXPECT_EQ(dynamic.find("removed by the mask"), std::string::npos);
  EXPECT_CONTAINS(dynamic, "removed by stage 1");
  EXPECT_CONTAINS(dynamic, "removed by stage 2");
}

TEST(ReportPlots, WithoutGroundTruthTheOthersAreMadeAndTheReasonGiven) {
  const Trajectory gt = groundTruth();
  const RunPlots plots = makeRunPlots(constructedReport(), estimate(gt), nullptr, "no groundtruth.txt in /x");
  ASSERT_EQ(plots.plots.size(), 2u);
  EXPECT_EQ(plots.plots[0].id, "dynamic_features");
  EXPECT_EQ(plots.plots[1].id, "stage_timings");
  ASSERT_EQ(plots.left_out.size(), 4u);
  for (const LeftOutPlot& p : plots.left_out) EXPECT_CONTAINS(p.reason, "no groundtruth.txt in /x");
  const json j = toJson(plots);
  EXPECT_EQ(j["files"].size(), 2u);
  EXPECT_EQ(j["left_out"].size(), 4u);
}

TEST(ReportPlots, GroundTruthOfAnotherSequenceLeavesThoseOutWithTheReason) {
  Trajectory gt = groundTruth();
  for (StampedPose& p : gt) p.timestamp += 1000;
  const RunPlots plots = makeRunPlots(constructedReport(), estimate(groundTruth()), &gt, "");
  EXPECT_EQ(plots.plots.size(), 2u);
  ASSERT_EQ(plots.left_out.size(), 4u);
  EXPECT_CONTAINS(plots.left_out[0].reason, "no timestamps within max_dt");
}

TEST(ReportHtml, PageIsSelfContainedAndNamesEveryFigure) {
  test::TempDir dir;
  const std::string png("\x89PNG\r\n\x1a\n fake image bytes \xff\x00", 26);
  dir.write("dense_map.png", png);
  RunFolder run;
  run.dir = dir.path();
  run.report = constructedReport();
  run.report["ate"] = {{"translation_m", {{"rmse", 0.0123}}}, {"matched", 60}};
  run.ground_truth = groundTruth();
  run.trajectory = estimate(*run.ground_truth);
  const RunPlots plots = makeRunPlots(run.report, run.trajectory, &*run.ground_truth, "");
  const std::string html = renderHtmlReport(run, plots);
  EXPECT_EQ(test::xmlProblem(html, {"meta", "br", "img"}), "");
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  for (const RunPlot& p : plots.plots) {
    EXPECT_CONTAINS(html, "id=\"" + p.id + "\"");
    EXPECT_CONTAINS(html, plot::xmlEscape(p.title));
  }
  EXPECT_CONTAINS(html, "src=\"data:image/png;base64," + base64Encode(png) + "\"");
  EXPECT_CONTAINS(html, "0.0123");  // the ATE of report.json in the figures table
  EXPECT_CONTAINS(html, "fx = 500");  // settings
  const std::regex external("(src|href)\\s*=\\s*\"(https?:)?//|url\\(\\s*['\"]?(https?:)?//|@import");
  EXPECT_FALSE(std::regex_search(html, external)) << "the page fetches nothing";
}

TEST(ReportHtml, WithoutDenseMapOrGroundTruthThePageSaysWhy) {
  test::TempDir dir;
  RunFolder run;
  run.dir = dir.path();
  run.report = constructedReport();
  run.report["dense"] = {{"enabled", false}};
  const RunPlots plots = makeRunPlots(run.report, run.trajectory, nullptr, "the sequence has no groundtruth.txt");
  const std::string html = renderHtmlReport(run, plots);
  EXPECT_CONTAINS(html, "no dense_map.png in the run folder (dense.enabled was false)");
  EXPECT_CONTAINS(html, "the sequence has no groundtruth.txt");
  EXPECT_CONTAINS(html, "none (no ground truth)");
}

TEST(ReportBase64, Rfc4648TestVectors) {
  EXPECT_EQ(base64Encode(""), "");
  EXPECT_EQ(base64Encode("f"), "Zg==");
  EXPECT_EQ(base64Encode("fo"), "Zm8=");
  EXPECT_EQ(base64Encode("foo"), "Zm9v");
  EXPECT_EQ(base64Encode("foob"), "Zm9vYg==");
  EXPECT_EQ(base64Encode("fooba"), "Zm9vYmE=");
  EXPECT_EQ(base64Encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64Encode(std::string("\xff\x00\xfe", 3)), "/wD+");
}

TEST(ReportRunFolder, BadInputNamesTheFileAndWhatToDo) {
  test::TempDir dir;
  const auto message = [](const std::filesystem::path& path) {
    try {
      loadRunFolder(path);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no InputError");
  };
  EXPECT_CONTAINS(message(dir / "missing"), "no such folder");
  EXPECT_CONTAINS(message(dir.path()), (dir / "report.json").string() + " not found");
  dir.write("report.json", "{\"statistics\": {");
  EXPECT_CONTAINS(message(dir.path()), "report.json is not valid JSON");
  dir.write("report.json", "{\"ate\": 1}");
  EXPECT_CONTAINS(message(dir.path()), "is not a `desslam run` report");
  dir.write("report.json", constructedReport().dump());
  const RunFolder run = loadRunFolder(dir.path());
  EXPECT_FALSE(run.ground_truth.has_value());
  EXPECT_CONTAINS(run.no_ground_truth_reason, "/nonexistent/sequence/groundtruth.txt does not exist");
  ASSERT_EQ(run.notes.size(), 1u);
  EXPECT_CONTAINS(run.notes[0], "CameraTrajectory.txt is missing");
  dir.write("CameraTrajectory.txt", "1.0 not a pose\n");
  EXPECT_CONTAINS(message(dir.path()), "CameraTrajectory.txt");
}

}  // namespace
}  // namespace desslam::report
