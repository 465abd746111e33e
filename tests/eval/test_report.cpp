#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.hpp"
#include "eval/evaluation.hpp"
#include "io/trajectory_io.hpp"
#include "support/shared_data.hpp"

namespace desslam::eval {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir()
      : path_(fs::temp_directory_path() /
              ("desslam_eval_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
               std::to_string(::getpid()))) {
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

TEST(EvalReport, JsonCarriesEveryStatistic) {
  AteResult ate;
  ate.translation_m = summarize({0.01, 0.02, 0.03});
  ate.matched = 3;
  ate.gt_poses = 10;
  ate.est_poses = 4;
  RpeResult rpe;
  rpe.translation_m = summarize({0.5});
  rpe.rotation_deg = summarize({2.0});
  rpe.pairs = 1;
  const nlohmann::json a = toJson(ate);
  EXPECT_DOUBLE_EQ(a["translation_m"]["median"].get<double>(), 0.02);
  EXPECT_EQ(a["matched"].get<int>(), 3);
  EXPECT_EQ(a["gt_poses"].get<int>(), 10);
  EXPECT_EQ(a["T_gt_est"]["quaternion_xyzw"].size(), 4u);
  const nlohmann::json r = toJson(rpe);
  EXPECT_DOUBLE_EQ(r["rotation_deg"]["rmse"].get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(r["delta_s"].get<double>(), 1.0);
  const std::string table = formatTable(ate, rpe, 0.02);
  EXPECT_NE(table.find("ATE [m]"), std::string::npos);
  EXPECT_NE(table.find("matched 3 of 4"), std::string::npos);
}

TEST(EvalReport, FilesWrittenInTumFormatEvaluateLikeInMemory) {
  // What `desslam eval` does: read both files, ATE + RPE; a shifted copy evaluates to zero.
  TempDir dir;
  Trajectory gt, est;
  for (int k = 0; k < 100; ++k) {
    const double s = k / 30.0;
    const SE3 pose(so3Exp(Vec3(0.02 * k, 0.01 * k, 0)), Vec3(std::sin(s), s * 0.3, std::cos(2 * s)));
    gt.push_back({1305031101.6258 + s, pose});
    est.push_back({1305031101.6258 + s + 0.004, SE3(so3Exp(Vec3(0, 0, 0.5)), Vec3(1, 2, 3)) * pose});
  }
  io::writeTumTrajectory(dir.path() / "gt.txt", gt);
  io::writeTumTrajectory(dir.path() / "est.txt", est);
  const Trajectory gt_read = io::readTumTrajectory(dir.path() / "gt.txt");
  const Trajectory est_read = io::readTumTrajectory(dir.path() / "est.txt");
  const AteResult ate = computeAte(gt_read, est_read, 0.02);
  EXPECT_EQ(ate.matched, 100u);
  EXPECT_LT(ate.translation_m.rmse, 1e-6);  // files hold nine decimals
  const RpeResult rpe = computeRpe(gt_read, est_read, 1.0, 0.02);
  EXPECT_GT(rpe.pairs, 60u);
  EXPECT_LT(rpe.translation_m.rmse, 1e-6);
  EXPECT_THROW(io::readTumTrajectory(dir.path() / "missing.txt"), InputError);
}

TEST(EvalReport, SharedClipGroundTruthAgainstItselfIsZero) {
  const fs::path gt_path = test::clipDir("fr1_xyz_0000_0099") / "groundtruth.txt";
  DESSLAM_REQUIRE_SHARED(gt_path);
  const Trajectory gt = io::readTumTrajectory(gt_path);
  const AteResult ate = computeAte(gt, gt, 0.02);
  EXPECT_EQ(ate.matched, gt.size());
  EXPECT_LT(ate.translation_m.rmse, 1e-9);
  const RpeResult rpe = computeRpe(gt, gt, 1.0, 0.02);
  EXPECT_GT(rpe.pairs, 0u);
  EXPECT_LT(rpe.rotation_deg.max, 1e-6);
}

}  // namespace
}  // namespace desslam::eval
