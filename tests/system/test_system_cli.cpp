// The desslam program as users run it: outputs of `desslam run`, identical results of two
// --deterministic runs, and clear failures (non-zero exit, the file or key named on stderr) on
// bad input.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/trajectory_io.hpp"
#include "support/shared_data.hpp"
#include "support/temp_dir.hpp"
#include "system_support.hpp"

namespace desslam {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::shellQuote;

#define EXPECT_CONTAINS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << "stderr lacks '" << (part) << "':\n" << (text)

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

TEST_F(DesslamCli, MissingArgumentsPrintUsage) {
  const CommandResult r = desslam("run");
  EXPECT_EQ(r.exit_code, 2);  // exit_code::kUsage
  EXPECT_FALSE(r.signaled);
  EXPECT_CONTAINS(r.err + r.out, "sequence");
}

}  // namespace
}  // namespace desslam
