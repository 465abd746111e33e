// The desslam program as users run it: outputs of `desslam run`, identical results of two
// --deterministic runs, and clear failures (non-zero exit, the file or key named on stderr) on
// bad input.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/trajectory_io.hpp"
#include "support/shared_data.hpp"
#include "support/expect_contains.hpp"
#include "support/temp_dir.hpp"
#include "system_support.hpp"

namespace desslam {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::shellQuote;

// A sequence folder and a config file for the synthetic camera in a fresh temp dir.
class DesslamCli : public ::testing::Test {
 protected:
  fs::path sequence() const { return dir_ / "sequence"; }
  fs::path config() const { return dir_ / "synthetic.yaml"; }
  fs::path out() const { return dir_ / "out"; }

  void writeSequence(int frames) { test::writeSyntheticSequence(sequence(), frames); }
  void writeConfig(const std::string& extra = "") { dir_.write("synthetic.yaml", test::syntheticConfigYaml(extra)); }

  CommandResult desslam(const std::string& arguments) {
    return test::runCommand(shellQuote(test::desslamBinary()) + " " + arguments, dir_ / "logs");
  }
  CommandResult run(const fs::path& seq, const fs::path& cfg, const fs::path& out_dir,
                    const std::string& extra = "") {
    return desslam("run " + shellQuote(seq.string()) + " --config " + shellQuote(cfg.string()) + " --out " +
                   shellQuote(out_dir.string()) + " " + extra);
  }
  // The default run of the tests below: the synthetic sequence and config.
  CommandResult run() { return run(sequence(), config(), out()); }

  // Frame i's file names as listed in rgb.txt / depth.txt (sorted by time, as written).
  std::vector<std::string> listed(const std::string& list) const {
    std::ifstream in(sequence() / list);
    std::vector<std::string> files;
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream fields(line);
      std::string stamp, file;
      fields >> stamp >> file;
      files.push_back(file);
    }
    return files;
  }

  // A failed run: non-zero exit, no crash, and a one-line "error: ..." naming what is wrong.
  static void expectCleanFailure(const CommandResult& r) {
    EXPECT_NE(r.exit_code, 0) << "stderr:\n" << r.err;
    EXPECT_FALSE(r.signaled) << "crashed (exit " << r.exit_code << "), stderr:\n" << r.err;
    EXPECT_CONTAINS(r.err, "error");
  }

  test::TempDir dir_;
};

// ---- outputs -------------------------------------------------------------------------------

TEST_F(DesslamCli, RunWritesTrajectoriesAndReport) {
  constexpr int kFrames = 45;
  writeSequence(kFrames);
  writeConfig();
  const CommandResult r = run(sequence(), config(), out(), "--deterministic");
  ASSERT_EQ(r.exit_code, 0) << "stderr:\n" << r.err << "\nstdout:\n" << r.out;

  // CameraTrajectory.txt: TUM format, 8 numeric columns per pose line.
  const fs::path camera_file = out() / "CameraTrajectory.txt";
  ASSERT_TRUE(fs::exists(camera_file));
  std::ifstream in(camera_file);
  std::string line;
  size_t pose_lines = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> values;
    double v;
    while (fields >> v) values.push_back(v);
    EXPECT_TRUE(fields.eof()) << "non-numeric field in: " << line;
    EXPECT_EQ(values.size(), 8u) << line;
    ++pose_lines;
  }
  const Trajectory camera = io::readTumTrajectory(camera_file);
  EXPECT_EQ(camera.size(), pose_lines);
  EXPECT_GE(camera.size(), static_cast<size_t>(0.99 * kFrames));

  const fs::path keyframe_file = out() / "KeyFrameTrajectory.txt";
  ASSERT_TRUE(fs::exists(keyframe_file));
  const Trajectory keyframes = io::readTumTrajectory(keyframe_file);
  EXPECT_GE(keyframes.size(), 1u);
  EXPECT_LE(keyframes.size(), camera.size());

  // report.json: settings, statistics (counts, tracking timing), ATE (ground truth exists).
  const fs::path report_file = out() / "report.json";
  ASSERT_TRUE(fs::exists(report_file));
  nlohmann::json report;
  ASSERT_NO_THROW(report = nlohmann::json::parse(test::readText(report_file)));
  ASSERT_TRUE(report.contains("settings"));
  EXPECT_DOUBLE_EQ(report["settings"]["camera"]["fx"].get<double>(), sim::syntheticCamera().fx);
  EXPECT_EQ(report["settings"]["semantic"]["segmenter"], "none");
  ASSERT_TRUE(report.contains("statistics"));
  const auto& stats = report["statistics"];
  ASSERT_TRUE(stats.contains("counts"));
  EXPECT_EQ(stats["counts"]["frames"].get<size_t>(), static_cast<size_t>(kFrames));
  EXPECT_EQ(stats["counts"]["frames_tracked"].get<size_t>(), camera.size());
  EXPECT_EQ(stats["counts"]["keyframes"].get<size_t>(), keyframes.size());
  ASSERT_TRUE(stats["timings_ms"]["tracking"]["median"].is_number()) << stats.dump(2);
  EXPECT_GT(stats["timings_ms"]["tracking"]["median"].get<double>(), 0.0);
  ASSERT_TRUE(report.contains("ate")) << report.dump(2);
  EXPECT_EQ(report["ate"]["matched"].get<size_t>(), camera.size());
  EXPECT_LT(report["ate"]["translation_m"]["rmse"].get<double>(), 0.005);
  ASSERT_TRUE(report.contains("rpe"));
  EXPECT_GT(report["rpe"]["pairs"].get<size_t>(), 0u);
  // Every step between consecutive poses checked against the speed limit, none beyond it.
  ASSERT_TRUE(report.contains("trajectory_check")) << report.dump(2);
  EXPECT_EQ(report["trajectory_check"]["steps_checked"].get<size_t>(), camera.size() - 1);
  EXPECT_EQ(report["trajectory_check"]["steps_faster_than_max_speed"].get<size_t>(), 0u);

  EXPECT_EQ(report["interrupted"], false);
  EXPECT_EQ(report["exit_code"], 0);
  EXPECT_FALSE(report.contains("error"));

  // No temporary files left behind.
  for (const auto& entry : fs::directory_iterator(out())) {
    EXPECT_NE(entry.path().extension(), ".tmp") << entry.path();
    EXPECT_EQ(entry.path().filename().string().rfind(".desslam-tmp", 0), std::string::npos) << entry.path();
  }
}

TEST_F(DesslamCli, EvalReadsWhatRunWrote) {
  writeSequence(40);
  writeConfig();
  ASSERT_EQ(run(sequence(), config(), out(), "--deterministic --quiet").exit_code, 0);
  const CommandResult r = desslam("eval " + shellQuote((sequence() / "groundtruth.txt").string()) + " " +
                                  shellQuote((out() / "CameraTrajectory.txt").string()) + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  nlohmann::json j;
  ASSERT_NO_THROW(j = nlohmann::json::parse(r.out)) << r.out;
  EXPECT_GE(j["ate"]["matched"].get<size_t>(), 39u);
  EXPECT_LT(j["ate"]["translation_m"]["rmse"].get<double>(), 0.005);
}

TEST_F(DesslamCli, RunWithoutGroundTruthHasNoAte) {
  writeSequence(20);
  writeConfig();
  fs::remove(sequence() / "groundtruth.txt");
  const CommandResult r = run(sequence(), config(), out(), "--deterministic --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto report = nlohmann::json::parse(test::readText(out() / "report.json"));
  EXPECT_FALSE(report.contains("ate"));
  EXPECT_EQ(report["statistics"]["counts"]["frames"].get<size_t>(), 20u);
}

// Ground truth that covers no frame, or a trajectory too short for an ATE: the console says why
// there is no ATE where the table would be (stdout; nothing with -q), report.json the same.
TEST_F(DesslamCli, RunWithoutAnAteSaysWhyOnTheConsole) {
  writeSequence(12);
  writeConfig();
  const fs::path gt = sequence() / "groundtruth.txt";
  std::string shifted;  // every ground-truth pose 1000 s after the frames
  std::istringstream lines(test::readText(gt));
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') {
      shifted += line + "\n";
      continue;
    }
    const size_t space = line.find(' ');
    char stamp[64];
    std::snprintf(stamp, sizeof stamp, "%.6f", std::stod(line.substr(0, space)) + 1000.0);
    shifted += stamp + line.substr(space) + "\n";
  }
  dir_.write("sequence/groundtruth.txt", shifted);
  const CommandResult r = run(sequence(), config(), out(), "--deterministic");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_CONTAINS(r.out, "ATE/RPE          n/a: no timestamps within max_dt: are these the same sequence?");
  nlohmann::json report = nlohmann::json::parse(test::readText(out() / "report.json"));
  EXPECT_FALSE(report.contains("ate"));
  EXPECT_CONTAINS(report["evaluation_error"].get<std::string>(), "no timestamps within max_dt");

  const CommandResult quiet = run(sequence(), config(), out(), "--deterministic --overwrite -q");
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.out, "");

  // The real ground truth, but 2 frames: too few poses for an ATE.
  writeSequence(12);
  const CommandResult two = run(sequence(), config(), out(), "--deterministic --overwrite --max-frames 2");
  ASSERT_EQ(two.exit_code, 0) << two.err;
  EXPECT_CONTAINS(two.out, "ATE/RPE          n/a: the main map's trajectory has 2 poses, too few: ATE needs at least 3");
  report = nlohmann::json::parse(test::readText(out() / "report.json"));
  EXPECT_CONTAINS(report["evaluation_error"].get<std::string>(), "has 2 poses, too few");
}

// ---- determinism ---------------------------------------------------------------------------

void expectIdenticalRuns(const fs::path& a, const fs::path& b) {
  for (const char* name : {"CameraTrajectory.txt", "KeyFrameTrajectory.txt"}) {
    const std::string first = test::readText(a / name), second = test::readText(b / name);
    EXPECT_FALSE(first.empty()) << a / name << " is empty";
    EXPECT_EQ(first, second) << name << " differs between two --deterministic runs";
  }
}

TEST_F(DesslamCli, DeterministicRunsAreByteIdenticalOnSyntheticData) {
  writeSequence(60);
  writeConfig();
  const CommandResult first = run(sequence(), config(), dir_ / "run1", "--deterministic --quiet");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const CommandResult second = run(sequence(), config(), dir_ / "run2", "--deterministic --quiet");
  ASSERT_EQ(second.exit_code, 0) << second.err;
  expectIdenticalRuns(dir_ / "run1", dir_ / "run2");
}

TEST_F(DesslamCli, DeterministicRunsAreByteIdenticalOnTheFr1Clip) {
  const fs::path clip = test::clipDir("fr1_xyz_0000_0099");
  DESSLAM_REQUIRE_SHARED(clip);
  const fs::path preset = test::sourceDir() / "config" / "tum_fr1.yaml";
  const CommandResult first = run(clip, preset, dir_ / "run1", "--deterministic --quiet");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const CommandResult second = run(clip, preset, dir_ / "run2", "--deterministic --quiet");
  ASSERT_EQ(second.exit_code, 0) << second.err;
  expectIdenticalRuns(dir_ / "run1", dir_ / "run2");
}

// ---- bad input -----------------------------------------------------------------------------

TEST_F(DesslamCli, MissingSequenceFolderIsNamed) {
  writeConfig();
  const fs::path missing = dir_ / "no_such_sequence";
  const CommandResult r = run(missing, config(), out());
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "no_such_sequence");
}

TEST_F(DesslamCli, MissingRgbListIsNamed) {
  writeSequence(3);
  writeConfig();
  fs::remove(sequence() / "rgb.txt");
  const CommandResult r = run();
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "rgb.txt");
}

TEST_F(DesslamCli, EmptyRgbListIsNamed) {
  writeSequence(3);
  writeConfig();
  std::ofstream(sequence() / "rgb.txt", std::ios::trunc) << "# color images\n";
  const CommandResult r = run();
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "rgb.txt");
}

TEST_F(DesslamCli, CorruptRgbImageIsNamed) {
  writeSequence(3);
  writeConfig();
  const std::vector<std::string> rgb = listed("rgb.txt");
  ASSERT_EQ(rgb.size(), 3u);
  // The second frame: the first has been processed when it fails.
  std::ofstream(sequence() / rgb[1], std::ios::binary | std::ios::trunc) << "this is not a PNG \x01\x02\x03";
  const CommandResult r = run();
  expectCleanFailure(r);
  EXPECT_EQ(r.exit_code, 1);  // exit_code::kBadInput
  EXPECT_CONTAINS(r.err, fs::path(rgb[1]).filename().string());
  // The run ends with what it computed: the first frame's trajectory and a report naming the error.
  nlohmann::json report;
  ASSERT_NO_THROW(report = nlohmann::json::parse(test::readText(out() / "report.json")));
  EXPECT_NE(report["error"].get<std::string>().find(fs::path(rgb[1]).filename().string()), std::string::npos);
  EXPECT_EQ(report["statistics"]["counts"]["frames"].get<size_t>(), 1u);
  EXPECT_TRUE(fs::exists(out() / "CameraTrajectory.txt"));
}

TEST_F(DesslamCli, EightBitDepthImageIsNamed) {
  writeSequence(3);
  writeConfig();
  const std::vector<std::string> depth = listed("depth.txt");
  ASSERT_EQ(depth.size(), 3u);
  const cv::Mat eight_bit(480, 640, CV_8UC1, cv::Scalar(100));
  ASSERT_TRUE(cv::imwrite((sequence() / depth[0]).string(), eight_bit));
  const CommandResult r = run();
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, fs::path(depth[0]).filename().string());
  EXPECT_CONTAINS(r.err, "16-bit");
}

TEST_F(DesslamCli, UnknownConfigKeyIsNamed) {
  writeSequence(3);
  writeConfig("tracking:\n  max_dept: 3.0\n");
  const CommandResult r = run();
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "tracking.max_dept");
  EXPECT_CONTAINS(r.err, "synthetic.yaml");
}

TEST_F(DesslamCli, BadConfigValueIsNamed) {
  writeSequence(3);
  writeConfig("orb:\n  num_levels: 0\n");
  const CommandResult r = run();
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "orb.num_levels");
}

TEST_F(DesslamCli, WrongTypeConfigValueIsNamed) {
  writeSequence(3);
  writeConfig("tracking:\n  max_depth: far\n");
  const CommandResult r = run();
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "tracking.max_depth");
}

TEST_F(DesslamCli, UnknownOverrideKeyIsNamed) {
  writeSequence(3);
  writeConfig();
  const CommandResult r = run(sequence(), config(), out(), "--set tracking.max_dept=3");
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "tracking.max_dept");
}

TEST_F(DesslamCli, SkipFramesWithholdsTheRangeAndSaysSo) {
  writeSequence(30);
  writeConfig();
  const CommandResult r = run(sequence(), config(), out(), "--deterministic -q --skip-frames 10-14");
  ASSERT_EQ(r.exit_code, 0) << "stderr:\n" << r.err;
  nlohmann::json report;
  ASSERT_NO_THROW(report = nlohmann::json::parse(test::readText(out() / "report.json")));
  EXPECT_EQ(report["settings"]["skip_frames"]["first"].get<size_t>(), 10u);
  EXPECT_EQ(report["settings"]["skip_frames"]["last"].get<size_t>(), 14u);
  EXPECT_EQ(report["statistics"]["counts"]["frames"].get<size_t>(), 25u);
  const auto& per_frame = report["statistics"]["per_frame"];
  ASSERT_EQ(per_frame.size(), 25u);
  EXPECT_EQ(per_frame[9]["input_index"].get<size_t>(), 9u);
  EXPECT_EQ(per_frame[10]["input_index"].get<size_t>(), 15u);
  // The withheld frames have no pose.
  const Trajectory camera = io::readTumTrajectory(out() / "CameraTrajectory.txt");
  EXPECT_LE(camera.size(), 25u);
}

TEST_F(DesslamCli, MalformedSkipFramesIsNamed) {
  writeSequence(3);
  writeConfig();
  for (const std::string value : {"200", "a-5", "9-2", "-4", "3-", "1-2-3"}) {
    SCOPED_TRACE(value);
    const CommandResult r = run(sequence(), config(), out(), "--skip-frames=" + value);
    expectCleanFailure(r);
    EXPECT_CONTAINS(r.err, "--skip-frames");
    EXPECT_CONTAINS(r.err, "FIRST-LAST");
  }
  // A range starting past the sequence's end skips nothing: refused, naming the frame count.
  const CommandResult past = run(sequence(), config(), out(), "--skip-frames 5-9");
  expectCleanFailure(past);
  EXPECT_CONTAINS(past.err, "--skip-frames");
  EXPECT_CONTAINS(past.err, "3 frames");
}

TEST_F(DesslamCli, EmulatedMaskLatencyIsRefusedWithRealtime) {
  // Real time has its own mask latency; emulating one on top of it would mean neither.
  writeSequence(3);
  writeConfig();
  const CommandResult r = run(sequence(), config(), out(), "--realtime --emulate-mask-latency 3");
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "latency");
  EXPECT_CONTAINS(r.err, "--realtime");
  EXPECT_FALSE(fs::exists(out() / "report.json"));
}

TEST_F(DesslamCli, EmulatedMaskLatencyOfflineRunsAndIsReported) {
  // The counterpart of the refusal above: offline, the same option is accepted and recorded.
  writeSequence(10);
  writeConfig();
  const CommandResult r =
      run(sequence(), config(), out(), "--deterministic -q --emulate-mask-latency 3 --emulate-mask-period 2");
  ASSERT_EQ(r.exit_code, 0) << "stderr:\n" << r.err;
  nlohmann::json report;
  ASSERT_NO_THROW(report = nlohmann::json::parse(test::readText(out() / "report.json")));
  EXPECT_EQ(report["settings"]["emulated_mask_latency"]["frames"].get<int>(), 3);
  EXPECT_EQ(report["settings"]["emulated_mask_latency"]["period"].get<int>(), 2);
}

TEST_F(DesslamCli, MissingConfigFileIsNamed) {
  writeSequence(3);
  const CommandResult r = run(sequence(), dir_ / "no_such_config.yaml", out());
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "no_such_config.yaml");
}

TEST_F(DesslamCli, EvalWithMissingFileIsNamed) {
  writeSequence(3);
  const CommandResult r = desslam("eval " + shellQuote((sequence() / "groundtruth.txt").string()) + " " +
                                  shellQuote((dir_ / "no_such_estimate.txt").string()));
  expectCleanFailure(r);
  EXPECT_CONTAINS(r.err, "no_such_estimate.txt");
}

// CameraTrajectory_all.txt of a run whose two maps were never merged: the second map's world is
// 5 m away. Each map aligned on its own is exact; one alignment across both would be metres off.
TEST_F(DesslamCli, EvalOfAnAtlasTrajectoryAlignsEachMapOnItsOwn) {
  writeSequence(8);
  const fs::path gt = sequence() / "groundtruth.txt";
  std::vector<std::string> poses;
  std::istringstream lines(test::readText(gt));
  for (std::string line; std::getline(lines, line);)
    if (!line.empty() && line[0] != '#') poses.push_back(line);
  ASSERT_GE(poses.size(), 6u);
  std::string all = "# timestamp tx ty tz qx qy qz qw map world_map\n";
  for (size_t i = 0; i < poses.size(); ++i) {
    std::istringstream f(poses[i]);
    double v[8];
    for (double& x : v) f >> x;
    const bool second = i >= poses.size() / 2;
    char row[256];
    std::snprintf(row, sizeof(row), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f %d %d\n", v[0], v[1] + (second ? 5.0 : 0.0),
                  v[2], v[3], v[4], v[5], v[6], v[7], second ? 2 : 0, second ? 2 : 0);
    all += row;
  }
  dir_.write("CameraTrajectory_all.txt", all);
  const std::string args = shellQuote(gt.string()) + " " + shellQuote((dir_ / "CameraTrajectory_all.txt").string());
  const CommandResult table = desslam("eval " + args);
  ASSERT_EQ(table.exit_code, 0) << table.err << table.out;
  EXPECT_CONTAINS(table.out, "2 maps never merged: each is aligned to the ground truth on its own");
  EXPECT_CONTAINS(table.out, "(every matched pose, each map aligned on its own)");
  const CommandResult json = desslam("eval --json " + args);
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const nlohmann::json report = nlohmann::json::parse(json.out);
  ASSERT_EQ(report["maps"].size(), 2u);
  EXPECT_EQ(report["maps"][1]["world_map"], 2);
  EXPECT_LT(report["maps"][0]["ate"]["translation_m"]["rmse"].get<double>(), 1e-4);
  EXPECT_LT(report["maps"][1]["ate"]["translation_m"]["rmse"].get<double>(), 1e-4);
  EXPECT_LT(report["ate_all_maps"]["rmse"].get<double>(), 1e-4);
  EXPECT_EQ(report["ate_all_maps"]["count"].get<size_t>(), poses.size());
}

TEST_F(DesslamCli, EvalOfTooFewPosesSaysHowManyTheEstimateHas) {
  writeSequence(4);
  const fs::path gt = sequence() / "groundtruth.txt";
  std::string two_poses;  // the ground truth's first two poses: both associate
  std::istringstream lines(test::readText(gt));
  for (std::string line; std::getline(lines, line) && std::count(two_poses.begin(), two_poses.end(), '\n') < 2;)
    if (!line.empty() && line[0] != '#') two_poses += line + "\n";
  for (const auto& [name, text, count] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"empty.txt", "", "0 poses"}, {"two.txt", two_poses, "2 poses"}}) {
    SCOPED_TRACE(name);
    dir_.write(name, text);
    const CommandResult r = desslam("eval " + shellQuote(gt.string()) + " " + shellQuote((dir_ / name).string()));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_CONTAINS(r.err, name + " against ");
    EXPECT_CONTAINS(r.err, "the estimate has " + count + ", too few: ATE needs at least 3");
    EXPECT_EQ(r.err.find("same sequence"), std::string::npos) << r.err;
  }
}

TEST_F(DesslamCli, MissingArgumentsPrintUsage) {
  const CommandResult r = desslam("run");
  EXPECT_EQ(r.exit_code, 2);  // exit_code::kUsage
  EXPECT_FALSE(r.signaled);
  EXPECT_CONTAINS(r.err + r.out, "sequence");
}

// ---- plausibility of the input (issue 11) ----------------------------------------------------

// 36 frames (1.2 s) of the synthetic sweep: the camera moves ~0.3 m in the first second.
constexpr int kPlausibilityFrames = 36;

TEST_F(DesslamCli, RightDepthFactorPassesSilently) {
  writeSequence(kPlausibilityFrames);
  writeConfig();
  const CommandResult r = run(sequence(), config(), out(), "--deterministic --quiet --max-frames 36");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("depth_factor"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(test::readText(out() / "report.json"));
  const auto& scale = report["plausibility"]["scale"];
  ASSERT_TRUE(scale["judged"].get<bool>()) << report["plausibility"].dump(2);
  EXPECT_NEAR(scale["ratio"].get<double>(), 1.0, 0.05);
  EXPECT_TRUE(report["plausibility"]["findings"].empty());
}

TEST_F(DesslamCli, WrongDepthFactorIsAnErrorNamingTheKeyAndTheLikelyFactor) {
  writeSequence(kPlausibilityFrames);
  writeConfig();
  for (const char* factor : {"1000", "25000"}) {  // x0.2 and x5 of the right 5000
    SCOPED_TRACE(factor);
    const CommandResult r = run(sequence(), config(), out(), std::string("--quiet --set camera.depth_factor=") + factor);
    EXPECT_EQ(r.exit_code, 1) << r.err;  // exit_code::kBadInput
    expectCleanFailure(r);
    EXPECT_CONTAINS(r.err, "camera.depth_factor");
    EXPECT_CONTAINS(r.err, "likely factor is 5000");
    EXPECT_CONTAINS(r.err, "--force");
    EXPECT_FALSE(fs::exists(out() / "report.json"));  // refused before the run
  }
}

TEST_F(DesslamCli, ForceTurnsTheDepthFactorErrorIntoAWarning) {
  writeSequence(kPlausibilityFrames);
  writeConfig();
  const CommandResult r = run(sequence(), config(), out(), "--quiet --deterministic --force --set camera.depth_factor=25000");
  EXPECT_NE(r.exit_code, 1) << r.err;
  EXPECT_FALSE(r.signaled) << r.err;
  EXPECT_CONTAINS(r.err, "WARNING (--force)");
  EXPECT_CONTAINS(r.err, "camera.depth_factor");
  const auto report = nlohmann::json::parse(test::readText(out() / "report.json"));
  EXPECT_TRUE(report["plausibility"]["forced"].get<bool>());
  EXPECT_NEAR(report["plausibility"]["scale"]["ratio"].get<double>(), 0.2, 0.02);
  EXPECT_EQ(report["statistics"]["counts"]["frames"].get<size_t>(), static_cast<size_t>(kPlausibilityFrames));
}

TEST_F(DesslamCli, WrongDepthFactorOnTheFr1ClipIsAnError) {
  const fs::path clip = test::clipDir("fr1_xyz_0000_0099");
  DESSLAM_REQUIRE_SHARED(clip);
  const fs::path preset = test::sourceDir() / "config" / "tum_fr1.yaml";
  for (const char* factor : {"1000", "25000"}) {
    SCOPED_TRACE(factor);
    const CommandResult r = run(clip, preset, out(), std::string("--quiet --set camera.depth_factor=") + factor);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_CONTAINS(r.err, "camera.depth_factor");
    EXPECT_CONTAINS(r.err, "likely factor is 5000");
  }
}

TEST_F(DesslamCli, DuplicateConfigKeysAndSectionsNameBothLines) {
  writeSequence(3);
  // syntheticConfigYaml() is 16 lines; `extra` starts at line 17.
  writeConfig("tracking:\n  max_depth: 3.0\n  max_depth: 3.5\n");
  const CommandResult key = run();
  EXPECT_EQ(key.exit_code, 1) << key.err;
  EXPECT_CONTAINS(key.err, "tracking.max_depth");
  EXPECT_CONTAINS(key.err, "line 18");
  EXPECT_CONTAINS(key.err, "line 19");
  EXPECT_CONTAINS(key.err, "synthetic.yaml");

  writeConfig("dense:\n  voxel_size: 0.02\n");  // dense: is already at line 15
  const CommandResult section = run();
  EXPECT_EQ(section.exit_code, 1) << section.err;
  EXPECT_CONTAINS(section.err, "section 'dense'");
  EXPECT_CONTAINS(section.err, "line 15");
  EXPECT_CONTAINS(section.err, "line 17");
}

TEST_F(DesslamCli, ImplausibleNumericValuesOfEverySubCommandAreRejected) {
  writeSequence(3);
  writeConfig();
  const std::string gt = shellQuote((sequence() / "groundtruth.txt").string());
  struct Case {
    std::string arguments, named;
  };
  const std::string run_base = "run " + shellQuote(sequence().string()) + " --config " + shellQuote(config().string()) +
                               " --out " + shellQuote(out().string()) + " ";
  const std::vector<Case> cases = {
      {run_base + "--set camera.fx=1e-9", "camera.fx"},
      {run_base + "--set camera.fx=1e300", "camera.fx"},
      {run_base + "--set camera.depth_factor=.nan", "camera.depth_factor"},
      {run_base + "--set tracking.max_depth=-5", "tracking.max_depth"},
      {run_base + "--max-frames -5", "--max-frames"},
      {run_base + "--emulate-mask-latency 1000", "--emulate-mask-latency"},
      {"eval " + gt + " " + gt + " --max-dt nan", "--max-dt"},
      {"eval " + gt + " " + gt + " --max-dt -1", "--max-dt"},
      {"eval " + gt + " " + gt + " --delta inf", "--delta"},
      {"mapcheck " + shellQuote(out().string()) + " " + shellQuote(sequence().string()) + " --tolerance nan", "--tolerance"},
      {"mapcheck " + shellQuote(out().string()) + " " + shellQuote(sequence().string()) + " --window -5", "--window"},
      {"vocab check " + shellQuote(sequence().string()) + " --vocab x.bin --max-translation inf", "--max-translation"},
      {"vocab check " + shellQuote(sequence().string()) + " --vocab x.bin --every 0", "--every"},
      {"vocab train " + gt + " --out v.bin --branching 1", "--branching"},
      {"vocab train " + gt + " --out v.bin --features-per-image -3", "--features-per-image"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.arguments);
    const CommandResult r = desslam(c.arguments);
    EXPECT_TRUE(r.exit_code == 1 || r.exit_code == 2) << "exit " << r.exit_code << "\n" << r.err;
    EXPECT_FALSE(r.signaled);
    EXPECT_CONTAINS(r.err, c.named);
    EXPECT_FALSE(fs::exists(out() / "report.json"));
  }
}

TEST_F(DesslamCli, EvalRefusesNonFinitePoses) {
  writeSequence(3);
  const fs::path gt = sequence() / "groundtruth.txt";
  for (const std::string& bad : {"nan", "inf", "1e300"}) {
    SCOPED_TRACE(bad);
    std::string text = test::readText(gt);
    // The second pose line's tx replaced.
    std::istringstream lines(text);
    std::string line, rewritten;
    int pose = 0;
    while (std::getline(lines, line)) {
      if (!line.empty() && line[0] != '#' && ++pose == 2) {
        std::istringstream f(line);
        std::string t, tx, rest;
        f >> t >> tx;
        std::getline(f, rest);
        line = t + " " + bad + rest;
      }
      rewritten += line + "\n";
    }
    dir_.write("estimate.txt", rewritten);
    const CommandResult r = desslam("eval " + shellQuote(gt.string()) + " " + shellQuote((dir_ / "estimate.txt").string()));
    EXPECT_EQ(r.exit_code, 1) << r.err << r.out;
    EXPECT_CONTAINS(r.err, "estimate.txt");
    EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("inf"), std::string::npos) << r.out;
  }
}

TEST_F(DesslamCli, UnknownSubCommandListsTheSubCommands) {
  const CommandResult r = desslam("frobnicate --help");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_CONTAINS(r.err, "unknown sub-command 'frobnicate'");
  for (const char* name : {"run", "eval", "vocab", "mapcheck"}) EXPECT_CONTAINS(r.err, name);
  const CommandResult nested = desslam("vocab tran");
  EXPECT_EQ(nested.exit_code, 2);
  EXPECT_CONTAINS(nested.err, "unknown sub-command 'tran' of desslam vocab");
  EXPECT_CONTAINS(nested.err, "train, check");
}

TEST_F(DesslamCli, MissingSubCommandListsTheSubCommands) {
  for (const char* arguments : {"", "--log-level warning"}) {
    SCOPED_TRACE(std::string("desslam ") + arguments);
    const CommandResult r = desslam(arguments);
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_FALSE(r.signaled);
    EXPECT_CONTAINS(r.err, "desslam needs a sub-command: type one of run, eval, vocab, mapcheck, report");
    EXPECT_CONTAINS(r.err, "desslam run --help");
  }
  const CommandResult nested = desslam("vocab");
  EXPECT_EQ(nested.exit_code, 2);
  EXPECT_CONTAINS(nested.err, "desslam vocab needs a sub-command: type one of train, check");
  // A missing option of a command without sub-commands is still CLI11's own message.
  const CommandResult option = desslam("eval");
  EXPECT_EQ(option.exit_code, 2);
  EXPECT_CONTAINS(option.err, "groundtruth is required");
}

TEST_F(DesslamCli, TimestampTiesAndBadGroundTruthAreWarnings) {
  writeSequence(8);
  writeConfig();
  const std::vector<std::string> rgb = listed("rgb.txt");
  // A second line with the first frame's timestamp, and an unreadable ground truth.
  std::ifstream in(sequence() / "rgb.txt");
  std::string first_stamp, line;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') {
      first_stamp = line.substr(0, line.find(' '));
      break;
    }
  std::ofstream(sequence() / "rgb.txt", std::ios::app) << first_stamp << " " << rgb[1] << "\n";
  std::ofstream(sequence() / "groundtruth.txt", std::ios::app) << "1000.5 nan 0 0 0 0 0 1\n";
  const CommandResult r = run(sequence(), config(), out(), "--deterministic --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Log lines go to stderr: stdout carries results only (empty with --quiet).
  EXPECT_CONTAINS(r.err, "rgb.txt");
  EXPECT_CONTAINS(r.err, "same timestamp");
  EXPECT_CONTAINS(r.err, "ignoring the ground truth");
  EXPECT_EQ(r.out.find("same timestamp"), std::string::npos) << "stdout:\n" << r.out;
  EXPECT_EQ(r.out.find("[warning]"), std::string::npos) << "stdout:\n" << r.out;
  // --log-level error keeps warnings out of stderr too.
  const CommandResult silent = desslam("--log-level error run " + shellQuote(sequence().string()) + " -c " +
                                       shellQuote(config().string()) + " -o " + shellQuote((out() / "silent").string()) +
                                       " --deterministic --quiet");
  ASSERT_EQ(silent.exit_code, 0) << silent.err;
  EXPECT_EQ(silent.err.find("same timestamp"), std::string::npos) << silent.err;
  const auto report = nlohmann::json::parse(test::readText(out() / "report.json"));
  EXPECT_FALSE(report.contains("ate"));
  EXPECT_GE(report["input_warnings"].size(), 2u);
  // vocab check needs the ground truth: there the same problem is an error.
  const CommandResult check = desslam("vocab check " + shellQuote(sequence().string()) + " --vocab " +
                                      shellQuote((test::sourceDir() / "vocab" / "desslam_orb_k10l5.bin").string()));
  EXPECT_EQ(check.exit_code, 1) << check.err;
  EXPECT_CONTAINS(check.err, "groundtruth.txt");
}

}  // namespace
}  // namespace desslam
