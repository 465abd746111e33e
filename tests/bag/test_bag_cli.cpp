// `desslam run <file.bag>` as users run it: the same trajectory as on the folder the bag was made
// from, intrinsics from camera_info when the config has none, and clear failures on bad bags.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "bag/bag_writer.hpp"
#include "io/trajectory_io.hpp"
#include "io/tum_dataset.hpp"
#include "sim/synthetic_scene.hpp"
#include "support/expect_contains.hpp"
#include "support/temp_dir.hpp"
#include "system/system_support.hpp"

namespace desslam {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::shellQuote;

class DesslamBagCli : public ::testing::Test {
 protected:
  static constexpr int kFrames = 30;

  void SetUp() override {
    test::writeSyntheticSequence(folder(), kFrames);
    dir_.write("synthetic.yaml", test::syntheticConfigYaml());
    bag::writeBag(io::TumSequence::open(folder()), sim::syntheticCamera(), bagFile());
  }
  fs::path folder() const { return dir_ / "synthetic"; }
  fs::path bagFile() const { return dir_ / "synthetic.bag"; }
  fs::path config() const { return dir_ / "synthetic.yaml"; }

  CommandResult run(const fs::path& input, const fs::path& cfg, const std::string& out, const std::string& extra = "") {
    return test::runCommand(shellQuote(test::desslamBinary()) + " run " + shellQuote(input.string()) + " --config " +
                                shellQuote(cfg.string()) + " --out " + shellQuote((dir_ / out).string()) +
                                " --deterministic --quiet " + extra,
                            dir_ / ("logs_" + out));
  }
  Trajectory trajectory(const std::string& out) const {
    return io::readTumTrajectory(dir_ / out / "CameraTrajectory.txt");
  }
  nlohmann::json report(const std::string& out) const {
    return nlohmann::json::parse(test::readText(dir_ / out / "report.json"));
  }
  static void expectSame(const Trajectory& a, const Trajectory& b) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t k = 0; k < a.size(); ++k) {
      EXPECT_NEAR(a[k].timestamp, b[k].timestamp, 1e-6) << "pose " << k;  // the file has 6 decimals
      EXPECT_LE((a[k].T_w_c.matrix() - b[k].T_w_c.matrix()).cwiseAbs().maxCoeff(), 1e-9) << "pose " << k;
    }
  }
  static void expectCleanFailure(const CommandResult& r) {
    EXPECT_EQ(r.exit_code, 1) << "stderr:\n" << r.err;
    EXPECT_FALSE(r.signaled) << r.err;
    EXPECT_CONTAINS(r.err, "error");
  }

  test::TempDir dir_;
};

TEST_F(DesslamBagCli, BagRunGivesTheFolderRunsTrajectory) {
  const CommandResult on_folder = run(folder(), config(), "folder");
  ASSERT_EQ(on_folder.exit_code, 0) << on_folder.err;
  const CommandResult on_bag = run(bagFile(), config(), "bag");
  ASSERT_EQ(on_bag.exit_code, 0) << on_bag.err;
  const Trajectory from_folder = trajectory("folder");
  EXPECT_GE(from_folder.size(), static_cast<size_t>(kFrames - 1));
  expectSame(trajectory("bag"), from_folder);
  const nlohmann::json settings = report("bag")["settings"];
  EXPECT_EQ(settings["camera_intrinsics_from"], "config");
  EXPECT_EQ(settings["bag"]["depth_topic"], "/camera/depth/image");
}

TEST_F(DesslamBagCli, ConfigWithoutIntrinsicsTakesThemFromCameraInfo) {
  dir_.write("no_intrinsics.yaml", "camera:\n  fps: 30\nsemantic:\n  segmenter: none\ndynamic:\n  mode: geometric\n"
                                   "dense:\n  enabled: false\n");
  const CommandResult on_bag = run(bagFile(), dir_ / "no_intrinsics.yaml", "info");
  ASSERT_EQ(on_bag.exit_code, 0) << on_bag.err;
  EXPECT_CONTAINS(on_bag.err, "camera intrinsics from ROS bag");
  const nlohmann::json settings = report("info")["settings"];
  EXPECT_EQ(settings["camera"]["fx"].get<double>(), sim::syntheticCamera().fx);
  EXPECT_EQ(settings["camera"]["width"].get<int>(), sim::syntheticCamera().width);
  EXPECT_CONTAINS(settings["camera_intrinsics_from"].get<std::string>(), "/camera/rgb/camera_info");
  ASSERT_EQ(run(folder(), config(), "folder").exit_code, 0);
  expectSame(trajectory("info"), trajectory("folder"));

  // A folder has no camera_info: the config must give the intrinsics.
  const CommandResult on_folder = run(folder(), dir_ / "no_intrinsics.yaml", "folder_no_intrinsics");
  expectCleanFailure(on_folder);
  EXPECT_CONTAINS(on_folder.err, "no_intrinsics.yaml");
  EXPECT_CONTAINS(on_folder.err, "camera.fx");
  // Half of the camera from the config is refused (geometry from one place).
  dir_.write("half.yaml", "camera:\n  width: 640\n  height: 480\n");
  const CommandResult half = run(bagFile(), dir_ / "half.yaml", "half");
  expectCleanFailure(half);
  EXPECT_CONTAINS(half.err, "camera.width");
}

TEST_F(DesslamBagCli, BadBagsAndTopicsFailNamingTheFix) {
  const CommandResult missing_topic = run(bagFile(), config(), "topic", "--set bag.depth_topic=/camera/depth_registered/image");
  expectCleanFailure(missing_topic);
  EXPECT_CONTAINS(missing_topic.err, "/camera/depth_registered/image");
  EXPECT_CONTAINS(missing_topic.err, "its topics are");
  EXPECT_CONTAINS(missing_topic.err, "/camera/depth/image (sensor_msgs/Image)");

  const CommandResult bad_name = run(bagFile(), config(), "name", "--set bag.rgb_topic=camera/rgb");
  expectCleanFailure(bad_name);
  EXPECT_CONTAINS(bad_name.err, "bag.rgb_topic");

  const fs::path not_a_bag = dir_.write("broken.bag", std::string(4096, 'x'));
  const CommandResult broken = run(not_a_bag, config(), "broken");
  expectCleanFailure(broken);
  EXPECT_CONTAINS(broken.err, "broken.bag");
  EXPECT_CONTAINS(broken.err, "ROS 1 bag");
}

}  // namespace
}  // namespace desslam
