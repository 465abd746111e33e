// The dense mapping thread: keyframes pushed from one thread while another fuses and updates
// poses (run under -DDESSLAM_TSAN=ON to check the lock discipline).
#include <atomic>
#include <thread>

#include <gtest/gtest.h>
#include <open3d/geometry/PointCloud.h>

#include "core/error.hpp"
#include "dense/dense_thread.hpp"
#include "dense_test_support.hpp"

namespace desslam::dense {
namespace {

using test::planeKeyframe;
using test::smallCamera;

std::shared_ptr<const DenseKeyframe> wallKeyframe(const PinholeCamera& camera, uint64_t id) {
  const SE3 T_w_c(Mat3::Identity(), Vec3(0.02 * static_cast<double>(id), 0, 0));
  return std::make_shared<const DenseKeyframe>(planeKeyframe(camera, id, static_cast<double>(id), T_w_c, Vec3::UnitZ(), 2.0));
}

DenseOptions threadOptions() {
  DenseOptions o;
  o.queue_capacity = 4;
  o.outlier_neighbors = 0;  // keeps fuse() cheap; filtering is tested elsewhere
  return o;
}

TEST(DenseMappingThread, PushFromOneThreadFuseAndUpdateFromAnother) {
  const PinholeCamera camera(smallCamera(80, 60));
  DenseMappingThread thread(threadOptions(), camera, QueueFullPolicy::kBlock);
  constexpr int kKeyframes = 30;
  std::atomic<bool> producing{true};
  std::thread producer([&] {
    for (int i = 0; i < kKeyframes; ++i) {
      if (!thread.push(wallKeyframe(camera, static_cast<uint64_t>(i)))) ADD_FAILURE() << "push " << i << " refused";
    }
    producing = false;
  });
  size_t fuses = 0;
  while (producing || fuses < 3) {
    const auto cloud = thread.fuse();
    for (const Eigen::Vector3d& p : cloud->points_) ASSERT_NEAR(p.z(), 2.0, 1e-3);
    thread.updatePoses({{0, SE3()}});  // keeps keyframe 0 at the origin
    ++fuses;
  }
  producer.join();
  // Keyframe 5 moves 1 m up (its voxels with it), then keyframe 6 is culled; both may still be queued.
  thread.updatePoses({{5, SE3(Mat3::Identity(), Vec3(0, 0, 1.0))}});
  thread.removeKeyframe(6);
  thread.waitUntilIdle();
  EXPECT_EQ(thread.processedCount(), static_cast<size_t>(kKeyframes));
  EXPECT_EQ(thread.keyframeCount(), static_cast<size_t>(kKeyframes));  // culled ones keep their voxels
  EXPECT_EQ(thread.droppedCount(), 0u);

  const DenseMap snapshot = thread.snapshot();
  EXPECT_TRUE(snapshot.isCulled(6));
  EXPECT_FALSE(snapshot.isCulled(7));
  EXPECT_DOUBLE_EQ(snapshot.poses().at(5).translation().z(), 1.0);
  size_t lifted = 0;
  const auto final_cloud = thread.fuse();  // a temporary shared_ptr would die before the loop
  for (const Eigen::Vector3d& p : final_cloud->points_) lifted += std::abs(p.z() - 3.0) < 1e-3 ? 1 : 0;
  EXPECT_GT(lifted, 100u);

  thread.stop();
  EXPECT_FALSE(thread.push(wallKeyframe(camera, 100)));
  thread.stop();  // idempotent
}

TEST(DenseMappingThread, RealTimeModeDropsTheOldestAndNeverBlocks) {
  const PinholeCamera camera(smallCamera(320, 240));
  DenseOptions options = threadOptions();
  options.queue_capacity = 2;
  DenseMappingThread thread(options, camera, QueueFullPolicy::kDropOldest);
  constexpr int kKeyframes = 40;
  for (int i = 0; i < kKeyframes; ++i) ASSERT_TRUE(thread.push(wallKeyframe(camera, static_cast<uint64_t>(i))));
  thread.waitUntilIdle();
  EXPECT_EQ(thread.processedCount(), static_cast<size_t>(kKeyframes));
  EXPECT_EQ(thread.keyframeCount() + thread.droppedCount(), static_cast<size_t>(kKeyframes));
  EXPECT_TRUE(thread.snapshot().contains(kKeyframes - 1));  // the newest is never dropped
}

TEST(DenseMappingThread, StopMapsWhatIsStillQueued) {
  const PinholeCamera camera(smallCamera(160, 120));
  DenseMappingThread thread(threadOptions(), camera);
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(thread.push(wallKeyframe(camera, static_cast<uint64_t>(i))));
  thread.stop();
  EXPECT_EQ(thread.keyframeCount(), 4u);
  EXPECT_GT(thread.fuse()->points_.size(), 0u);
}

// A keyframe the worker cannot map (here: a depth image of the wrong size) used to end the
// program (std::terminate); now the worker keeps the exception for the pipeline and stays usable.
TEST(DenseMappingThread, FailureIsKeptAndTheThreadGoesIdle) {
  const PinholeCamera camera(smallCamera(80, 60));
  DenseMappingThread thread(threadOptions(), camera, QueueFullPolicy::kBlock);
  ASSERT_TRUE(thread.push(wallKeyframe(camera, 0)));
  auto bad = std::make_shared<DenseKeyframe>(*wallKeyframe(camera, 1));
  bad->depth = cv::Mat(10, 10, CV_32F, cv::Scalar(1.0f));
  ASSERT_TRUE(thread.push(bad));
  thread.waitUntilIdle();
  ASSERT_TRUE(thread.failure());
  EXPECT_THROW(std::rethrow_exception(thread.failure()), InputError);
  EXPECT_FALSE(thread.push(wallKeyframe(camera, 2)));  // nothing more is mapped
  thread.waitUntilIdle();
  EXPECT_EQ(thread.keyframeCount(), 1u);  // what was mapped before stays
  thread.stop();
}

}  // namespace
}  // namespace desslam::dense
