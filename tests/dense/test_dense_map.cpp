// Back-projection, fusion, exclusion and pose updates of the dense map; the free-space check;
// export and read-back (PLY, PCD, OctoMap, PNG).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/PointCloud.h>

#include "dense/dense_map.hpp"
#include "dense/map_check.hpp"
#include "dense/map_export.hpp"
#include "dense_test_support.hpp"

namespace desslam::dense {
namespace {

using test::noFilterOptions;
using test::planeKeyframe;
using test::smallCamera;

// Camera at the origin looking along +z at a plane tilted 30 degrees about x.
TEST(BackProjector, PlanePointsLieOnThePlaneAndCountFollowsTheStride) {
  const PinholeCamera camera(smallCamera());
  const Vec3 n = Vec3(0, std::sin(M_PI / 6), std::cos(M_PI / 6)).normalized();
  const double d = 2.0;
  const DenseKeyframe kf = planeKeyframe(camera, 1, 0.0, SE3(), n, d);
  for (int stride : {1, 2, 3, 5}) {
    DenseOptions options;
    options.pixel_stride = stride;
    options.max_depth = 10.0;
    const KeyframeCloud cloud = BackProjector(options, camera)(kf);
    const size_t expected = static_cast<size_t>((camera.width() + stride - 1) / stride) *
                            static_cast<size_t>((camera.height() + stride - 1) / stride);
    EXPECT_EQ(cloud.size(), expected) << "stride " << stride;
    double worst = 0;
    for (const Eigen::Vector3f& p : cloud.points_c) worst = std::max(worst, std::abs(n.dot(p.cast<double>()) - d));
    EXPECT_LT(worst, 1e-3) << "stride " << stride;
    ASSERT_EQ(cloud.rgb.size(), cloud.size());
    EXPECT_EQ(cloud.rgb.front(), (std::array<uint8_t, 3>{220, 160, 40}));  // BGR in, RGB out
  }
}

TEST(BackProjector, DepthOutsideRangeAndWrongImagesAreHandled) {
  const PinholeCamera camera(smallCamera(64, 48));
  DenseKeyframe kf = planeKeyframe(camera, 7, 0.0, SE3(), Vec3::UnitZ(), 5.0);  // beyond max_depth 4
  DenseOptions options;
  EXPECT_EQ(BackProjector(options, camera)(kf).size(), 0u);
  kf.depth.convertTo(kf.depth, CV_16U);
  try {
    BackProjector(options, camera)(kf);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 7"), std::string::npos) << e.what();
  }
}

TEST(BackProjector, ExcludedPixelsAndTheirDilatedBorderGiveNoPoints) {
  const PinholeCamera camera(smallCamera());
  DenseKeyframe kf = planeKeyframe(camera, 1, 0.0, SE3(), Vec3::UnitZ(), 2.0);
  kf.exclude_mask = cv::Mat(camera.height(), camera.width(), CV_8U, cv::Scalar(0));
  const cv::Rect person(200, 100, 120, 260);
  kf.exclude_mask(person).setTo(255);
  DenseOptions options;
  options.pixel_stride = 1;
  options.exclude_dilation_px = 4;
  const KeyframeCloud cloud = BackProjector(options, camera)(kf);
  const cv::Rect grown(person.x - 4, person.y - 4, person.width + 8, person.height + 8);
  size_t inside_grown = 0;
  for (const Eigen::Vector3f& p : cloud.points_c) {
    const Vec2 uv = camera.project(p.cast<double>());
    const cv::Point px(static_cast<int>(std::lround(uv.x())), static_cast<int>(std::lround(uv.y())));
    ASSERT_FALSE(person.contains(px)) << "point from an excluded pixel " << px;
    inside_grown += grown.contains(px) ? 1 : 0;
  }
  // Only the corners of the grown box (outside the elliptic dilation) may keep points.
  EXPECT_LT(inside_grown, 4u * 16u);
  EXPECT_LT(cloud.size(), static_cast<size_t>(camera.width() * camera.height() - person.area()));
  EXPECT_GT(cloud.size(), static_cast<size_t>(camera.width() * camera.height() - grown.area()));
}

TEST(BackProjector, FlyingPixelsAtDepthEdgesAreDropped) {
  const PinholeCamera camera(smallCamera(64, 48));
  DenseKeyframe kf = planeKeyframe(camera, 1, 0.0, SE3(), Vec3::UnitZ(), 3.0);
  kf.depth(cv::Rect(0, 0, 32, 48)).setTo(1.0);  // a step: left half at 1 m, right half at 3 m
  DenseOptions options;
  options.pixel_stride = 1;
  const size_t with_filter = BackProjector(options, camera)(kf).size();
  options.depth_edge_ratio = 0;
  const size_t without = BackProjector(options, camera)(kf).size();
  EXPECT_EQ(without, 64u * 48u);
  EXPECT_EQ(with_filter, 64u * 48u - 2u * 48u);  // the columns either side of the step
}

TEST(VoxelDownsample, AveragesWithinVoxelsAndKeepsTheMajorityLabel) {
  KeyframeCloud cloud;
  cloud.points_c = {{0.001f, 0.001f, 1.001f}, {0.003f, 0.001f, 1.001f}, {0.005f, 0.001f, 1.001f}, {0.5f, 0.5f, 1.5f}};
  cloud.rgb = {{0, 0, 0}, {30, 30, 30}, {60, 60, 60}, {1, 2, 3}};
  cloud.labels = {15, 0, 15, 9};
  const KeyframeCloud out = voxelDownsample(cloud, 0.01);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_NEAR(out.points_c[0].x(), 0.003f, 1e-6f);
  EXPECT_EQ(out.rgb[0], (std::array<uint8_t, 3>{30, 30, 30}));
  EXPECT_EQ(out.labels[0], 15);
  EXPECT_EQ(out.labels[1], 9);
}

// Two cameras 0.4 m apart, one turned 10 degrees, both seeing the wall z_w = 3.
class TwoViewsOfAWall : public ::testing::Test {
 protected:
  PinholeCamera camera{smallCamera()};
  SE3 T_w_a = SE3();
  SE3 T_w_b = SE3(Mat3(Eigen::AngleAxisd(10 * M_PI / 180, Vec3::UnitY())), Vec3(0.4, 0.05, -0.2));
  DenseKeyframe a = planeKeyframe(camera, 1, 0.0, T_w_a, Vec3::UnitZ(), 3.0);
  DenseKeyframe b = planeKeyframe(camera, 2, 1.0, T_w_b, Vec3::UnitZ(), 3.0);
};

TEST_F(TwoViewsOfAWall, FusedPointsLieOnTheWallAndTheViewsAreMerged) {
  DenseOptions options;
  DenseMap map(options, camera);
  map.addKeyframe(a);
  map.addKeyframe(b);
  EXPECT_EQ(map.keyframeCount(), 2u);
  const auto fused = map.fuse({{1, T_w_a}, {2, T_w_b}});
  ASSERT_GT(fused->points_.size(), 1000u);
  for (const Eigen::Vector3d& p : fused->points_) ASSERT_NEAR(p.z(), 3.0, 1e-3);

  // Merging: every pixel mapped (0.6 cm apart on the wall, finer than the 1 cm voxels, so a
  // fills every voxel of its footprint) and the wall mid-voxel (z = 3.005), so b's points
  // where a has been can only join a's voxels.
  options.pixel_stride = 1;
  DenseMap dense(options, camera);
  dense.addKeyframe(planeKeyframe(camera, 1, 0.0, T_w_a, Vec3::UnitZ(), 3.005));
  const size_t voxels_a = dense.voxelCount();
  dense.addKeyframe(planeKeyframe(camera, 2, 1.0, T_w_b, Vec3::UnitZ(), 3.005));

  // Where b sees what a saw, b's points were merged into a's voxels: the voxels anchored at b
  // (worldScans groups by anchor) lie almost all outside a's footprint.
  const std::vector<WorldScan> scans = dense.worldScans();
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_EQ(scans[0].points_w.size(), voxels_a);
  const double half_width = 3.0 * (camera.width() / 2.0) / camera.fx() - 0.05;
  const double half_height = 3.0 * (camera.height() / 2.0) / camera.fy() - 0.05;
  size_t b_inside_a = 0;
  for (const Vec3& p : scans[1].points_w) b_inside_a += std::abs(p.x()) < half_width && std::abs(p.y()) < half_height;
  EXPECT_GT(scans[1].points_w.size(), 1000u);  // b's new part of the wall
  EXPECT_LT(b_inside_a, voxels_a / 50) << "b's views of a's part should have been merged";
  EXPECT_EQ(dense.voxelCount(), voxels_a + scans[1].points_w.size());
}

TEST_F(TwoViewsOfAWall, PoseUpdatesMoveTheFusedCloud) {
  DenseMap map(noFilterOptions(), camera);
  map.addKeyframe(a);
  const auto before = map.fuse();
  // A loop closure moves the keyframe 0.5 m along x and turns it 5 degrees about z.
  const SE3 correction(Mat3(Eigen::AngleAxisd(5 * M_PI / 180, Vec3::UnitZ())), Vec3(0.5, 0, 0));
  map.updatePoses({{1, correction * T_w_a}, {99, SE3()}});  // unknown id 99 is ignored
  EXPECT_EQ(map.keyframeCount(), 1u);
  const auto after = map.fuse();
  const auto given = DenseMap(map).fuse({{1, correction * T_w_a}});
  ASSERT_EQ(after->points_.size(), given->points_.size());

  open3d::geometry::PointCloud expected;
  for (const Eigen::Vector3d& p : before->points_) expected.points_.push_back(correction * p);
  const open3d::geometry::KDTreeFlann tree(expected);
  for (const Eigen::Vector3d& p : after->points_) {
    std::vector<int> index;
    std::vector<double> dist2;
    tree.SearchKNN(p, 1, index, dist2);
    ASSERT_LT(std::sqrt(dist2[0]), 0.015) << p.transpose();  // world voxel grids differ
  }
  const Vec3 shift = after->GetCenter() - before->GetCenter();
  EXPECT_GT(shift.norm(), 0.3);  // the cloud really moved

  // A culled keyframe keeps its voxels and still follows the poses sent for it.
  map.removeKeyframe(1);
  EXPECT_TRUE(map.isCulled(1));
  EXPECT_EQ(map.keyframeCount(), 1u);
  map.updatePoses({{1, T_w_a}});
  const auto back = map.fuse();
  ASSERT_EQ(back->points_.size(), before->points_.size());
  EXPECT_LT((back->GetCenter() - before->GetCenter()).norm(), 1e-3);
}

TEST(DenseMap, SemanticColouringUsesTheLabelPalette) {
  const PinholeCamera camera(smallCamera(64, 48));
  DenseKeyframe kf = planeKeyframe(camera, 1, 0.0, SE3(), Vec3::UnitZ(), 2.0);
  kf.labels = cv::Mat(48, 64, CV_8U, cv::Scalar(15));
  DenseMap map(noFilterOptions(), camera);
  map.addKeyframe(kf);
  const auto cloud = map.fuse(true);
  ASSERT_FALSE(cloud->colors_.empty());
  EXPECT_EQ(semanticColour(15), (std::array<uint8_t, 3>{192, 128, 128}));  // VOC "person"
  EXPECT_NEAR(cloud->colors_[0].x(), 192 / 255.0, 1e-9);
  EXPECT_NEAR(cloud->colors_[0].y(), 128 / 255.0, 1e-9);
}

TEST(DenseMap, StatisticalOutlierRemovalDropsIsolatedPoints) {
  const PinholeCamera camera(smallCamera(160, 120));
  DenseKeyframe kf = planeKeyframe(camera, 1, 0.0, SE3(), Vec3::UnitZ(), 2.0);
  // A few isolated specks far in front of the wall (as left by sensor noise).
  for (int i = 0; i < 5; ++i) kf.depth.at<float>(20 + 20 * i, 30 + 20 * i) = 0.6f + 0.1f * i;
  DenseOptions options;
  options.pixel_stride = 1;
  options.depth_edge_ratio = 0;  // keep the specks through back-projection
  DenseMap map(options, camera);
  map.addKeyframe(kf);
  const auto fused = map.fuse();
  for (const Eigen::Vector3d& p : fused->points_) ASSERT_NEAR(p.z(), 2.0, 1e-3);
  options.outlier_neighbors = 0;
  DenseMap unfiltered(options, camera);
  unfiltered.addKeyframe(kf);
  size_t specks = 0;
  const auto unfiltered_cloud = unfiltered.fuse();  // a temporary shared_ptr would die before the loop
  for (const Eigen::Vector3d& p : unfiltered_cloud->points_) specks += p.z() < 1.5 ? 1 : 0;
  EXPECT_GT(specks, 0u);
}

// A wall at z = 2 seen at t = 1 from the origin; points made at t = 0.
TEST(FreeSpaceViolations, GhostInFrontOfAWallIsCountedWallPointsAreNot) {
  const PinholeCamera camera(smallCamera());
  const DenseKeyframe later = planeKeyframe(camera, 5, 1.0, SE3(), Vec3::UnitZ(), 2.0);
  std::vector<Vec3> points;
  std::vector<Timestamp> times;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> lateral(-0.8, 0.8);
  for (int i = 0; i < 100; ++i) {  // on the wall, or up to 4 cm in front (within tolerance)
    points.emplace_back(lateral(rng), lateral(rng) * 0.7, 2.0 - 0.04 * (i % 2));
    times.push_back(0.0);
  }
  for (int i = 0; i < 25; ++i) {  // ghosts of a person who has left
    points.emplace_back(lateral(rng) * 0.5, lateral(rng) * 0.5, 1.0 + 0.02 * i);
    times.push_back(0.0);
  }
  for (int i = 0; i < 10; ++i) {  // made by the keyframe itself: no later view
    points.emplace_back(0.0, 0.0, 1.0);
    times.push_back(1.0);
  }
  for (int i = 0; i < 7; ++i) {  // behind the camera, or outside the image
    points.emplace_back(0.1 * i, 0.0, -1.0);
    times.push_back(0.0);
  }
  const MapCheckResult result = freeSpaceViolations(points, times, {later}, camera);
  EXPECT_EQ(result.checked, 125u);
  EXPECT_EQ(result.violations, 25u);
  EXPECT_DOUBLE_EQ(result.share(), 0.2);

  EXPECT_THROW(freeSpaceViolations(points, {0.0}, {later}, camera), InputError);
}

TEST_F(TwoViewsOfAWall, MapOfAStaticWallHasNoFreeSpaceViolations) {
  DenseMap map(DenseOptions{}, camera);
  map.addKeyframe(a);
  map.addKeyframe(b);
  const MapCheckResult result = freeSpaceViolations(map.worldScans(), {a, b}, camera);
  EXPECT_GT(result.checked, 1000u);
  EXPECT_EQ(result.violations, 0u);
}

// ---- export ------------------------------------------------------------------------------

class ExportTest : public TwoViewsOfAWall {
 protected:
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() /
          ("desslam_dense_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  void TearDown() override { std::filesystem::remove_all(dir); }
  std::filesystem::path dir;
};

TEST_F(ExportTest, PlyAndPcdReadBackWithTheSamePointsAndColours) {
  DenseMap map(DenseOptions{}, camera);
  map.addKeyframe(a);
  const auto cloud = map.fuse();
  writePly(dir / "map.ply", *cloud);
  writePcd(dir / "map.pcd", *cloud);
  for (const char* name : {"map.ply", "map.pcd"}) {
    const auto back = readPointCloud(dir / name);
    ASSERT_EQ(back->points_.size(), cloud->points_.size()) << name;
    ASSERT_TRUE(back->HasColors()) << name;
    EXPECT_NEAR((back->points_[10] - cloud->points_[10]).norm(), 0.0, 1e-5) << name;
    EXPECT_NEAR((back->colors_[10] - cloud->colors_[10]).norm(), 0.0, 1.0 / 255) << name;
  }
  EXPECT_THROW(writePly(dir / "missing_folder" / "map.ply", *cloud), OutputError);
  EXPECT_THROW(readPointCloud(dir / "nothing.ply"), InputError);
}

TEST_F(ExportTest, OctomapFromRaysHasOccupiedWallAndFreeSpaceBeforeIt) {
  DenseMap map(DenseOptions{}, camera);
  map.addKeyframe(a);
  map.addKeyframe(b);
  const double resolution = 0.05;
  writeOctomap(dir / "map.bt", map.worldScans(), resolution, 5.0);
  const OctomapSummary rays = readOctomap(dir / "map.bt");
  EXPECT_DOUBLE_EQ(rays.resolution, resolution);
  ASSERT_GT(rays.occupied_centres.size(), 100u);
  for (const Vec3& c : rays.occupied_centres) ASSERT_NEAR(c.z(), 3.0, resolution) << c.transpose();
  ASSERT_FALSE(rays.free_centres.empty());
  for (const Vec3& c : rays.free_centres) ASSERT_LT(c.z(), 3.0) << c.transpose();

  writeOctomap(dir / "points.bt", *map.fuse(), resolution);
  const OctomapSummary points = readOctomap(dir / "points.bt");
  EXPECT_GT(points.occupied_centres.size(), 100u);
  EXPECT_TRUE(points.free_centres.empty());

  EXPECT_THROW(readOctomap(dir / "map.ply"), InputError);
  EXPECT_THROW(writeOctomap(dir / "no" / "map.bt", map.worldScans(), resolution, 5.0), OutputError);
}

std::string fileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The interruptible insertion writes exactly what OctoMap's own per-scan insertion writes (the
// export before it could be interrupted): the same file, byte for byte, with rays that reach the
// wall and rays cut at max_range.
TEST_F(ExportTest, OctomapFromRaysIsByteForByteOctomapsOwnInsertion) {
  DenseMap map(DenseOptions{}, camera);
  map.addKeyframe(a);
  map.addKeyframe(b);
  const std::vector<WorldScan> scans = map.worldScans();
  for (const auto& [resolution, max_range] : std::vector<std::pair<double, double>>{{0.05, 5.0}, {0.03, 3.1}}) {
    SCOPED_TRACE(resolution);
    octomap::OcTree reference(resolution);
    for (const WorldScan& scan : scans) {
      octomap::Pointcloud points;
      for (const Vec3& p : scan.points_w)
        points.push_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
      const octomap::point3d origin(static_cast<float>(scan.origin_w.x()), static_cast<float>(scan.origin_w.y()),
                                    static_cast<float>(scan.origin_w.z()));
      reference.insertPointCloud(points, origin, max_range, /*lazy_eval=*/true, /*discretize=*/true);
    }
    reference.updateInnerOccupancy();
    ASSERT_TRUE(reference.writeBinary((dir / "reference.bt").string()));
    writeOctomap(dir / "map.bt", scans, resolution, max_range);
    const std::string written = fileBytes(dir / "map.bt"), expected = fileBytes(dir / "reference.bt");
    EXPECT_GT(expected.size(), 1000u);
    EXPECT_TRUE(written == expected) << "octomap.bt differs from octomap::OcTree::insertPointCloud's";
  }
}

TEST_F(ExportTest, OctomapExportReportsProgressAndStopsWhenAborted) {
  DenseMap map(DenseOptions{}, camera);
  map.addKeyframe(a);
  map.addKeyframe(b);
  std::vector<double> shares;
  const auto record = [&shares](double share) { shares.push_back(share); };
  ASSERT_TRUE(writeOctomap(dir / "map.bt", map.worldScans(), 0.02, 5.0, nullptr, record));
  ASSERT_GE(shares.size(), 4u);  // at least the start and the cell updates of each of 2 scans
  EXPECT_EQ(shares.front(), 0.0);
  EXPECT_EQ(shares.back(), 1.0);
  EXPECT_TRUE(std::is_sorted(shares.begin(), shares.end()));

  // Aborted at its second report (e.g. a second signal during the export): nothing is written.
  std::atomic<bool> abort{false};
  int reports = 0;
  const bool written = writeOctomap(dir / "aborted.bt", map.worldScans(), 0.02, 5.0, &abort,
                                    [&](double) { abort = ++reports >= 2; });
  EXPECT_FALSE(written);
  EXPECT_EQ(reports, 2) << "stopped right after the report that set the flag";
  EXPECT_FALSE(std::filesystem::exists(dir / "aborted.bt"));
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().rfind(".desslam-tmp", 0), std::string::npos) << entry.path();
}

TEST_F(ExportTest, OctomapCostGrowsWithTheResolutionAndBoundsIt) {
  DenseMap map(DenseOptions{}, camera);
  map.addKeyframe(a);
  map.addKeyframe(b);
  const std::vector<WorldScan> scans = map.worldScans();
  const OctomapCost coarse = octomapCost(scans, 0.1, 5.0), fine = octomapCost(scans, 0.025, 5.0);
  EXPECT_GT(coarse.rays, 100u);
  EXPECT_GT(fine.rays, coarse.rays);
  EXPECT_GT(fine.cells(), 8 * coarse.cells());  // 4x finer: at least 4^1.5 as many cells
  EXPECT_LE(fine.cells(), fine.ray_cells + static_cast<double>(fine.rays));
  // The estimate is not below the cells the tree really got (its leaves, before pruning).
  octomap::OcTree tree(0.025);
  for (const WorldScan& scan : scans) {
    octomap::Pointcloud points;
    for (const Vec3& p : scan.points_w)
      points.push_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    tree.insertPointCloud(points, octomap::point3d(static_cast<float>(scan.origin_w.x()),
                                                   static_cast<float>(scan.origin_w.y()),
                                                   static_cast<float>(scan.origin_w.z())),
                          5.0, true, true);
  }
  EXPECT_GE(fine.cells(), static_cast<double>(tree.getNumLeafNodes()));
  EXPECT_LE(fine.cells(), 4.0 * static_cast<double>(tree.getNumLeafNodes()));

  // Bounded at what 0.1 m gives: 0.025 m is coarsened by doublings to the finest that fits.
  const double bounded = boundedOctomapResolution(scans, 0.025, 5.0, coarse.cells());
  EXPECT_GT(bounded, 0.025);
  EXPECT_LE(bounded, 0.1 + 1e-12);
  EXPECT_NEAR(std::log2(bounded / 0.025), std::round(std::log2(bounded / 0.025)), 1e-9);
  EXPECT_LE(octomapCost(scans, bounded, 5.0).cells(), coarse.cells());
  EXPECT_GT(octomapCost(scans, bounded / 2, 5.0).cells(), coarse.cells());
  EXPECT_EQ(boundedOctomapResolution(scans, 0.025, 5.0, fine.cells()), 0.025);  // fits: unchanged
}

TEST_F(ExportTest, RendererKeepsTheNearerSurfaceAndWritesAPng) {
  // Red square 1 m in front of the view, blue square behind it at 2 m, both centred.
  open3d::geometry::PointCloud cloud;
  for (double x = -0.2; x <= 0.2; x += 0.005) {
    for (double y = -0.2; y <= 0.2; y += 0.005) {
      cloud.points_.emplace_back(x, y, 1.0);
      cloud.colors_.emplace_back(1, 0, 0);
      cloud.points_.emplace_back(3 * x, 3 * y, 2.0);
      cloud.colors_.emplace_back(0, 0, 1);
    }
  }
  RenderSettings settings;
  settings.width = 200;
  settings.height = 150;
  settings.point_size = 0.02;
  settings.T_w_view = SE3();
  const cv::Mat image = renderMap(cloud, {}, settings);
  ASSERT_EQ(image.size(), cv::Size(200, 150));
  const cv::Vec3b centre = image.at<cv::Vec3b>(75, 100);
  EXPECT_GT(centre[2], 150);  // red (BGR)
  EXPECT_EQ(centre[0], 0);
  const cv::Vec3b corner = image.at<cv::Vec3b>(75, 44);  // only the far square reaches here
  EXPECT_GT(corner[0], 50);
  EXPECT_EQ(corner[2], 0);

  renderPng(dir / "map.png", cloud, {SE3()}, RenderSettings{});
  EXPECT_GT(std::filesystem::file_size(dir / "map.png"), 1000u);
}

}  // namespace
}  // namespace desslam::dense
