// How `desslam run` ends when it does not simply run to the end: stop signals at several points
// (the binary as a child process, held at a stage by DESSLAM_HOLD_AT and signalled there), output
// that cannot be written, an --out folder of an earlier run, and a run that tracks nothing.
#include <sys/wait.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.hpp"
#include "core/exit_codes.hpp"
#include "io/trajectory_io.hpp"
#include "support/expect_contains.hpp"
#include "support/temp_dir.hpp"
#include "system_support.hpp"

namespace desslam {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::shellQuote;

class RunControl : public ::testing::Test {
 protected:
  fs::path sequence() const { return dir_ / "sequence"; }
  fs::path config() const { return dir_ / "synthetic.yaml"; }
  fs::path out() const { return dir_ / "out"; }

  void prepare(int frames) {
    test::writeSyntheticSequence(sequence(), frames);
    dir_.write("synthetic.yaml", test::syntheticConfigYaml());
  }

  std::vector<std::string> runArgs(const std::vector<std::string>& extra = {}) const {
    std::vector<std::string> args = {test::desslamBinary(), "run",           sequence().string(), "--config",
                                     config().string(),     "--out",         out().string(),      "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }
  // The program, held (DESSLAM_HOLD_AT) at `holds`, as a child process.
  test::ChildProcess start(const std::string& holds, const std::vector<std::string>& extra = {}) {
    return test::spawnProcess(runArgs(extra), dir_ / "logs", {{"DESSLAM_HOLD_AT", holds}});
  }
  CommandResult run(const std::string& extra = "", const std::string& prefix = "") {
    std::string command = prefix;
    for (const std::string& a : runArgs()) command += shellQuote(a) + " ";
    return test::runCommand(command + extra, dir_ / "logs");
  }

  // Ground-truth timestamps: frame i's time.
  Trajectory groundTruth() const { return io::readTumTrajectory(sequence() / "groundtruth.txt"); }

  nlohmann::json report() const {
    nlohmann::json j;
    EXPECT_NO_THROW(j = nlohmann::json::parse(test::readText(out() / "report.json"))) << "report.json unreadable";
    return j;
  }

  // Every trajectory file is whole TUM (8 numbers per pose line; the atlas file 10), and the
  // camera trajectory has one pose per processed frame, the first `frames` frames of the sequence.
  void expectTrajectoriesOfFirstFrames(size_t frames) const {
    for (const auto& [name, columns] :
         std::vector<std::pair<std::string, size_t>>{{"CameraTrajectory.txt", 8}, {"CameraTrajectory_all.txt", 10},
                                                      {"KeyFrameTrajectory.txt", 8}}) {
      SCOPED_TRACE(name);
      ASSERT_TRUE(fs::exists(out() / name));
      std::istringstream lines(test::readText(out() / name));
      std::string line;
      while (std::getline(lines, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream fields(line);
        std::vector<double> values;
        double v;
        while (fields >> v) values.push_back(v);
        EXPECT_TRUE(fields.eof()) << line;
        EXPECT_EQ(values.size(), columns) << line;
      }
    }
    const Trajectory camera = io::readTumTrajectory(out() / "CameraTrajectory.txt");
    const Trajectory gt = groundTruth();
    ASSERT_EQ(camera.size(), frames);  // the synthetic room is tracked in every frame
    for (size_t i = 0; i < frames; ++i) EXPECT_NEAR(camera[i].timestamp, gt[i].timestamp, 1e-6) << i;
    EXPECT_GE(io::readTumTrajectory(out() / "KeyFrameTrajectory.txt").size(), 1u);
    for (const auto& entry : fs::directory_iterator(out()))
      EXPECT_FALSE(isAtomicTempName(entry.path().filename().string())) << "left behind: " << entry.path();
  }

  void expectInterrupted(const CommandResult& r, int signal_number, const char* name, const char* stage) const {
    EXPECT_FALSE(r.signaled) << "killed by the signal instead of handling it; stderr:\n" << r.err;
    EXPECT_EQ(r.exit_code, exit_code::interrupted(signal_number)) << r.err;
    EXPECT_CONTAINS(r.err, std::string("interrupted by ") + name);
    const nlohmann::json j = report();
    EXPECT_EQ(j["interrupted"], true);
    EXPECT_EQ(j["interruption"]["signal"], name);
    EXPECT_EQ(j["interruption"]["signal_number"], signal_number);
    EXPECT_EQ(j["interruption"]["stage"], stage);
    EXPECT_EQ(j["exit_code"], exit_code::interrupted(signal_number));
  }

  test::TempDir dir_;
};

// ---- signals -----------------------------------------------------------------------------------

TEST_F(RunControl, SigtermMidRunKeepsEveryProcessedFrame) {
  prepare(14);
  const test::ChildProcess child = start("frame:5");
  ASSERT_TRUE(child.waitForStderr("holding at frame:5")) << test::readText(child.err_file);
  child.signal(SIGTERM);
  const CommandResult r = child.wait();
  expectInterrupted(r, SIGTERM, "SIGTERM", "the frame loop");
  expectTrajectoriesOfFirstFrames(6);
  const nlohmann::json j = report();
  EXPECT_EQ(j["interruption"]["next_frame_index"], 6);
  EXPECT_EQ(j["interruption"]["frames_processed"], 6);
  EXPECT_EQ(j["interruption"]["final_global_ba"], "skipped");
  EXPECT_EQ(j["statistics"]["counts"]["frames"], 6);
}

TEST_F(RunControl, SigintBeforeTheFinalBundleAdjustmentSkipsItAndFinishes) {
  prepare(16);
  const test::ChildProcess child = start("final_ba");
  ASSERT_TRUE(child.waitForStderr("holding at final_ba")) << test::readText(child.err_file);
  child.signal(SIGINT);
  const CommandResult r = child.wait();
  expectInterrupted(r, SIGINT, "SIGINT", "final_ba");
  expectTrajectoriesOfFirstFrames(16);
  EXPECT_EQ(report()["interruption"]["final_global_ba"], "skipped");
  EXPECT_EQ(report()["interruption"]["next_frame_index"], 16);
}

TEST_F(RunControl, SighupDuringExportStillExportsTheDenseMap) {
  prepare(16);
  const test::ChildProcess child = start("export", {"--set", "dense.enabled=true"});
  ASSERT_TRUE(child.waitForStderr("holding at export")) << test::readText(child.err_file);
  child.signal(SIGHUP);
  const CommandResult r = child.wait();
  expectInterrupted(r, SIGHUP, "SIGHUP", "export");
  expectTrajectoriesOfFirstFrames(16);
  EXPECT_TRUE(fs::exists(out() / "dense_map.ply"));
  EXPECT_TRUE(fs::exists(out() / "octomap.bt"));
  EXPECT_EQ(report()["dense"]["exported"], true);
}

TEST_F(RunControl, SecondSignalSkipsTheDenseExportButWritesTrajectoriesAndReport) {
  prepare(12);
  const test::ChildProcess child = start("frame:4,export", {"--set", "dense.enabled=true"});
  ASSERT_TRUE(child.waitForStderr("holding at frame:4")) << test::readText(child.err_file);
  child.signal(SIGINT);
  ASSERT_TRUE(child.waitForStderr("holding at export")) << test::readText(child.err_file);
  child.signal(SIGINT);
  const CommandResult r = child.wait();
  expectInterrupted(r, SIGINT, "SIGINT", "the frame loop");
  EXPECT_CONTAINS(r.err, "second signal");
  expectTrajectoriesOfFirstFrames(5);
  const nlohmann::json j = report();
  EXPECT_EQ(j["interruption"]["signals"], 2);
  EXPECT_EQ(j["interruption"]["optional_stages_skipped"], true);
  EXPECT_EQ(j["dense"]["exported"], false);
  EXPECT_FALSE(fs::exists(out() / "dense_map.ply"));
}

// A long OctoMap export (held at its progress reports): the first signal is acknowledged at once
// and the export goes on, the second stops it; the run still writes trajectories and report.json.
TEST_F(RunControl, SecondSignalDuringTheOctomapExportStopsIt) {
  prepare(12);
  const test::ChildProcess child = start("octomap", {"--set", "dense.enabled=true"});
  ASSERT_TRUE(child.waitForStderr("holding at octomap")) << test::readText(child.err_file);
  child.signal(SIGINT);
  ASSERT_TRUE(child.waitForStderr("holding at octomap", 120, 2)) << test::readText(child.err_file);
  EXPECT_CONTAINS(test::readText(child.err_file), "interrupted by SIGINT (2) during export");
  child.signal(SIGINT);
  const CommandResult r = child.wait();
  expectInterrupted(r, SIGINT, "SIGINT", "export");
  EXPECT_CONTAINS(r.err, "second signal during export");
  expectTrajectoriesOfFirstFrames(12);
  const nlohmann::json j = report();
  EXPECT_EQ(j["interruption"]["signals"], 2);
  EXPECT_EQ(j["dense"]["exported"], true);
  EXPECT_EQ(j["dense"]["skipped"], (nlohmann::json{"octomap.bt", "dense_map.png"}));
  EXPECT_TRUE(fs::exists(out() / "dense_map.ply"));
  EXPECT_FALSE(fs::exists(out() / "octomap.bt"));
  for (const auto& entry : fs::directory_iterator(out()))
    EXPECT_FALSE(isAtomicTempName(entry.path().filename().string())) << "left behind: " << entry.path();
}

// An OctoMap resolution whose tree would be far too large for dense.octomap_max_cells is
// coarsened before the export starts, with a warning naming both options.
TEST_F(RunControl, TooFineOctomapIsCoarsenedWithAWarning) {
  prepare(12);
  const CommandResult r = run("--set dense.enabled=true --set dense.octomap_resolution=0.001 "
                              "--set dense.octomap_max_cells=2e5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_CONTAINS(r.err, "warning: dense map: dense.octomap_resolution = 0.001 m would give an OctoMap of about");
  EXPECT_CONTAINS(r.err, "more than dense.octomap_max_cells = 2e+05");
  EXPECT_CONTAINS(r.err, "raise dense.octomap_max_cells");
  const nlohmann::json octomap = report()["dense"]["octomap"];
  EXPECT_EQ(octomap["resolution_configured"], 0.001);
  const double used = octomap["resolution"].get<double>();
  EXPECT_GE(used, 0.002);
  EXPECT_NEAR(std::log2(used / 0.001), std::round(std::log2(used / 0.001)), 1e-9) << used;  // doublings
  EXPECT_LE(octomap["cells_estimated"].get<double>(), 2e5);
  EXPECT_GT(octomap["cells_estimated_configured"].get<double>(), 2e5);
  EXPECT_TRUE(fs::exists(out() / "octomap.bt"));
  EXPECT_CONTAINS(r.err, "octomap.bt is written at " + octomap["resolution"].dump() + " m instead");
}

// ---- outputs that cannot be written --------------------------------------------------------------

TEST_F(RunControl, OutThatIsAFileIsRefusedBeforeTheFirstFrame) {
  prepare(3);
  for (const fs::path& bad : {dir_.write("a_file", "not a folder"), fs::path("/dev/full")}) {
    SCOPED_TRACE(bad);
    std::string command;
    for (std::string a : runArgs()) command += shellQuote(a == out().string() ? bad.string() : a) + " ";
    const CommandResult r = test::runCommand(command, dir_ / "logs");
    EXPECT_EQ(r.exit_code, exit_code::kOutputError) << r.err;
    EXPECT_FALSE(r.signaled);
    EXPECT_CONTAINS(r.err, "error");
    EXPECT_CONTAINS(r.err, bad.string());
    EXPECT_CONTAINS(r.err, "not a folder");
  }
}

// A write that fails half-way (a file-size limit: tests run as root, for whom permissions stop
// nothing): the error names the file and the reason, the exit status is non-zero, no half file.
TEST_F(RunControl, FailedWriteIsNamedAndLeavesNoHalfFile) {
  prepare(16);  // CameraTrajectory.txt: ~1.6 kB, over the 1 kB limit; KeyFrameTrajectory.txt fits
  const CommandResult r = run("", "ulimit -f 2; trap '' XFSZ; exec ");
  EXPECT_FALSE(r.signaled) << r.err;
  EXPECT_EQ(r.exit_code, exit_code::kOutputError) << r.err;
  EXPECT_CONTAINS(r.err, "CameraTrajectory.txt");
  EXPECT_CONTAINS(r.err, "File too large");
  EXPECT_FALSE(fs::exists(out() / "CameraTrajectory.txt"));
  EXPECT_FALSE(fs::exists(out() / "report.json"));  // larger still
  EXPECT_TRUE(fs::exists(out() / "KeyFrameTrajectory.txt"));
  for (const auto& entry : fs::directory_iterator(out()))
    EXPECT_FALSE(isAtomicTempName(entry.path().filename().string())) << "left behind: " << entry.path();
}

// ---- the --out folder of an earlier run -----------------------------------------------------------

TEST_F(RunControl, EarlierRunIsRefusedAndOverwriteRemovesOnlyItsFiles) {
  prepare(12);
  ASSERT_EQ(run().exit_code, 0);
  const std::string first_report = test::readText(out() / "report.json");

  const CommandResult again = run();
  EXPECT_EQ(again.exit_code, exit_code::kBadInput);
  EXPECT_CONTAINS(again.err, "--overwrite");
  EXPECT_CONTAINS(again.err, "earlier run");
  EXPECT_EQ(test::readText(out() / "report.json"), first_report);  // untouched

  // Foreign files stay; a run's own files and a killed run's temporary file go.
  dir_.write("out/notes.txt", "mine");
  dir_.write("out/dense_map.ply", "stale");
  dir_.write("out/.desslam-tmp-99999-report.json", "half");
  const CommandResult overwritten = run("--overwrite");
  ASSERT_EQ(overwritten.exit_code, 0) << overwritten.err;
  EXPECT_EQ(test::readText(out() / "notes.txt"), "mine");
  EXPECT_FALSE(fs::exists(out() / "dense_map.ply"));  // dense map off in this config: removed, not rewritten
  EXPECT_FALSE(fs::exists(out() / ".desslam-tmp-99999-report.json"));
  EXPECT_EQ(report()["interrupted"], false);
  EXPECT_EQ(report()["exit_code"], 0);
}

// ---- a run that tracks nothing --------------------------------------------------------------------

TEST_F(RunControl, NothingTrackedWritesTheReportAndSaysWhy) {
  constexpr int kFrames = 12;
  prepare(kFrames);
  // All-zero depth: what a covered camera or a wrong depth format gives.
  const cv::Mat zero(480, 640, CV_16UC1, cv::Scalar(0));
  for (const auto& entry : fs::directory_iterator(sequence() / "depth"))
    ASSERT_TRUE(cv::imwrite(entry.path().string(), zero));
  const CommandResult r = run("--set dense.enabled=true");
  EXPECT_EQ(r.exit_code, exit_code::kNothingTracked) << r.err;
  EXPECT_FALSE(r.signaled);
  EXPECT_CONTAINS(r.err, "0 of 12 frames had 500 or more keypoints with valid depth");
  EXPECT_CONTAINS(r.err, "is the camera covered");
  EXPECT_CONTAINS(r.err, "camera.depth_factor");
  EXPECT_CONTAINS(r.err, "dense map is empty");
  EXPECT_EQ(r.err.find("error"), std::string::npos) << r.err;  // no "cannot write PLY"
  const nlohmann::json j = report();
  EXPECT_EQ(j["statistics"]["counts"]["frames"], kFrames);
  EXPECT_EQ(j["statistics"]["counts"]["frames_with_pose"], 0);
  EXPECT_EQ(j["exit_code"], exit_code::kNothingTracked);
  EXPECT_TRUE(j["nothing_tracked"].is_string());
  EXPECT_EQ(j["dense"]["exported"], false);
  EXPECT_FALSE(fs::exists(out() / "dense_map.ply"));
  EXPECT_TRUE(io::readTumTrajectory(out() / "CameraTrajectory.txt").empty());
}

// Masks covering the whole view (mask_dir, one all-dynamic PNG per frame): every frame has
// keypoints with depth, but the masks take them all; the message says so, not "spread".
TEST_F(RunControl, NothingTrackedBecauseTheMasksCoverEverythingSaysSo) {
  constexpr int kFrames = 8;
  prepare(kFrames);
  const fs::path masks = dir_ / "masks";
  fs::create_directories(masks);
  const cv::Mat everything(480, 640, CV_8UC1, cv::Scalar(255));
  for (const auto& entry : fs::directory_iterator(sequence() / "rgb"))
    ASSERT_TRUE(cv::imwrite((masks / entry.path().filename()).string(), everything));
  const CommandResult r = run("--dynamic semantic --set semantic.segmenter=mask_dir --set " +
                              shellQuote("semantic.mask_dir=" + masks.string()));
  EXPECT_EQ(r.exit_code, exit_code::kNothingTracked) << r.err;
  EXPECT_CONTAINS(r.err, "of 8 frames had 500 or more keypoints with valid depth");
  EXPECT_CONTAINS(r.err, "but none kept 500 once the dynamic features were removed (dynamic.mode semantic)");
  EXPECT_CONTAINS(r.err, "all but 0 of its");
  EXPECT_CONTAINS(r.err, "lay in the dynamic-object masks");
  EXPECT_CONTAINS(r.err, "are the masks in semantic.mask_dir (" + masks.string() + ") right");
  EXPECT_EQ(r.err.find("spread"), std::string::npos) << r.err;
  const nlohmann::json j = report();
  EXPECT_CONTAINS(j["nothing_tracked"].get<std::string>(), "dynamic-object masks");
  const nlohmann::json& first = j["statistics"]["per_frame"][0];
  EXPECT_GE(first["features_with_depth"].get<int>(), 500);
  EXPECT_EQ(first["static_with_depth"].get<int>(), 0);
  EXPECT_EQ(first["semantic_removed"], first["features"]);
}

}  // namespace
}  // namespace desslam
