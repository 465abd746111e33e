#include <cmath>
#include <iostream>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/camera.hpp"
#include "core/error.hpp"
#include "tracking/relocaliser.hpp"
#include "tracking/relocalisation_scene.hpp"

namespace desslam::tracking {
namespace {

constexpr double kDegree = M_PI / 180.0;

PinholeCamera tumCamera() {
  CameraOptions c;
  c.fx = 517.3;
  c.fy = 516.5;
  c.cx = 318.6;
  c.cy = 255.3;
  return PinholeCamera(c);
}

// 100 correspondences seen by a camera at T_c_w: `outliers` of them get a random pixel.
struct Correspondences {
  std::vector<Vec3> points_w;
  std::vector<Vec2> uv;
  std::vector<bool> is_outlier;
};

Correspondences makeCorrespondences(const PinholeCamera& camera, const SE3& T_c_w, int count, int outliers,
                                    double pixel_sigma, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, pixel_sigma);
  Correspondences c;
  const SE3 T_w_c = T_c_w.inverse();
  for (int i = 0; i < count; ++i) {
    const Vec2 pixel(u(rng) * camera.width(), u(rng) * camera.height());
    const double depth = 1.0 + 3.0 * u(rng);
    c.points_w.push_back(T_w_c * camera.backProject(pixel, depth));
    const bool outlier = i < outliers;
    c.is_outlier.push_back(outlier);
    c.uv.push_back(outlier ? Vec2(u(rng) * camera.width(), u(rng) * camera.height())
                           : Vec2(pixel + Vec2(noise(rng), noise(rng))));
  }
  return c;
}

double translationError(const SE3& a, const SE3& b) {
  return (a.inverse().translation() - b.inverse().translation()).norm();
}
double rotationErrorDeg(const SE3& a, const SE3& b) { return (a * b.inverse()).rotationAngle() / kDegree; }

TEST(SolvePnpRansac, RecoversPoseDespiteFortyPercentOutliers) {
  const PinholeCamera camera = tumCamera();
  RelocalisationOptions options;
  std::mt19937 rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    const SE3 T_c_w(so3Exp(Vec3(0.3, -0.5, 0.2) * (trial + 1) * 0.5), Vec3(0.4 * trial, -0.2, 1.0));
    const Correspondences c = makeCorrespondences(camera, T_c_w, 100, 40, 0.2, rng);
    const PnpResult result = solvePnpRansac(c.points_w, c.uv, camera, options);
    ASSERT_TRUE(result.ok) << "trial " << trial;
    EXPECT_LT(translationError(result.T_c_w, T_c_w), 1e-3) << "trial " << trial;
    EXPECT_LT(rotationErrorDeg(result.T_c_w, T_c_w), 0.1) << "trial " << trial;
    // The inliers are the 60 true correspondences (a random outlier pixel can land within the
    // threshold by chance, rarely).
    int true_inliers = 0, false_inliers = 0;
    for (int k : result.inliers) (c.is_outlier[static_cast<size_t>(k)] ? false_inliers : true_inliers)++;
    EXPECT_GE(true_inliers, 58) << "trial " << trial;
    EXPECT_LE(false_inliers, 2) << "trial " << trial;
  }
}

TEST(SolvePnpRansac, RejectsCorrespondencesWithoutConsensus) {
  const PinholeCamera camera = tumCamera();
  RelocalisationOptions options;
  std::mt19937 rng(9);
  const Correspondences c = makeCorrespondences(camera, SE3(), 100, 100, 0.0, rng);
  const PnpResult result = solvePnpRansac(c.points_w, c.uv, camera, options);
  EXPECT_FALSE(result.ok);
  EXPECT_LT(static_cast<int>(result.inliers.size()), options.min_pnp_inliers);

  // Too few correspondences to try at all.
  const Correspondences few = makeCorrespondences(camera, SE3(), 10, 0, 0.0, rng);
  EXPECT_FALSE(solvePnpRansac(few.points_w, few.uv, camera, options).ok);

  std::vector<Vec2> short_uv(c.uv.begin(), c.uv.begin() + 5);
  EXPECT_THROW(solvePnpRansac(c.points_w, short_uv, camera, options), InputError);
}

TEST(RelocalisationOptions, ValidateNamesTheKey) {
  RelocalisationOptions options;
  EXPECT_NO_THROW(options.validate());
  options.min_pnp_inliers = 2;
  try {
    options.validate();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("relocalisation.min_pnp_inliers"), std::string::npos) << e.what();
  }
  options = {};
  options.min_inliers = 10;  // below min_pnp_inliers
  EXPECT_THROW(options.validate(), ConfigError);
  options = {};
  options.ransac_reprojection_px = 0;
  EXPECT_THROW(options.validate(), ConfigError);
}

// A map of the synthetic room built by tracking + local mapping along the first part of a sweep;
// then frames from far back on the path (and a view the map never saw) are presented to the
// relocaliser without any prior.
class RelocaliserScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { scene_ = new test::RelocalisationScene(test::RelocalisationScene::Settings{}); }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }
  static test::RelocalisationScene* scene_;
};
test::RelocalisationScene* RelocaliserScene::scene_ = nullptr;

TEST_F(RelocaliserScene, MapCoversTheFirstPartOfThePath) {
  ASSERT_TRUE(scene_->allTracked()) << "the map must be built without losing track";
  EXPECT_GE(scene_->database().size(), 5u);
  std::cout << scene_->database().size() << " keyframes in the database, " << scene_->map().pointCount()
            << " map points\n";
  // The camera moved on: the frames tested below are far from where tracking stopped.
  EXPECT_GT(scene_->distanceFromLastTracked(5), 0.6);
}

TEST_F(RelocaliserScene, RecoversEarlierVisitedViewsWithoutPrior) {
  const Relocaliser relocaliser = scene_->relocaliser();
  for (int index : {5, 20, 40}) {
    map::Frame frame = scene_->frameAt(index);
    frame.T_c_w = scene_->lastTrackedPose();  // a stale prior must not matter
    const RelocalisationResult result = relocaliser.relocalise(frame);
    ASSERT_TRUE(result.success) << "path frame " << index << ": " << result.candidates << " candidates tried";
    ASSERT_NE(result.keyframe, nullptr);
    const SE3 expected = scene_->groundTruthTcw(index);
    EXPECT_LT(translationError(frame.T_c_w, expected), 0.02) << "path frame " << index;
    EXPECT_LT(rotationErrorDeg(frame.T_c_w, expected), 1.0) << "path frame " << index;
    EXPECT_GE(result.inliers, RelocalisationOptions{}.min_inliers);
    std::cout << "path frame " << index << ": " << result.inliers << " inliers, keyframe " << result.keyframe->id
              << " (candidate " << result.candidates << "), error " << translationError(frame.T_c_w, expected) * 1000
              << " mm, " << rotationErrorDeg(frame.T_c_w, expected) << " deg\n";
    int matched = 0;
    for (const map::FeatureMatch& m : frame.matches) matched += m.point != nullptr ? 1 : 0;
    EXPECT_EQ(matched, result.inliers) << "the frame keeps exactly the inlier matches";
  }
}

TEST_F(RelocaliserScene, GuidedSearchAddsTheNeighbourhoodsPoints) {
  // Word-level matching against one keyframe gives ~190 inliers here; demanding more forces the
  // guided search over the candidate's covisible keyframes' points to find the rest.
  RelocalisationOptions options;
  options.min_inliers = 260;
  const Relocaliser relocaliser(options, scene_->camera(), scene_->map(), scene_->database(), scene_->bf());
  map::Frame frame = scene_->frameAt(20);
  const RelocalisationResult result = relocaliser.relocalise(frame);
  std::cout << "with guided search: " << result.inliers << " inliers\n";
  ASSERT_TRUE(result.success);
  EXPECT_GE(result.inliers, 260);
  const SE3 expected = scene_->groundTruthTcw(20);
  EXPECT_LT(translationError(frame.T_c_w, expected), 0.02);
  EXPECT_LT(rotationErrorDeg(frame.T_c_w, expected), 1.0);
}

TEST_F(RelocaliserScene, RejectsAViewTheMapNeverSaw) {
  const Relocaliser relocaliser = scene_->relocaliser();
  // Turned round towards the back wall, which the sweep (looking along +y) never sees.
  map::Frame frame = scene_->frameLookingBack(20);
  const SE3 prior = frame.T_c_w;
  const RelocalisationResult result = relocaliser.relocalise(frame);
  std::cout << "unseen view: " << result.candidates << " candidates tried, none accepted\n";
  EXPECT_FALSE(result.success) << result.inliers << " inliers with keyframe "
                               << (result.keyframe ? result.keyframe->id : 0);
  for (const map::FeatureMatch& m : frame.matches) EXPECT_FALSE(m.matched());
  EXPECT_LT(translationError(frame.T_c_w, prior), 1e-12) << "a failed attempt leaves the pose alone";
}

TEST_F(RelocaliserScene, FailsCleanlyWithAnEmptyDatabase) {
  place::KeyframeDatabase empty(scene_->vocabulary(), RelocalisationOptions{}.direct_index_level);
  const Relocaliser relocaliser(RelocalisationOptions{}, scene_->camera(), scene_->map(), empty, scene_->bf());
  map::Frame frame = scene_->frameAt(5);
  const RelocalisationResult result = relocaliser.relocalise(frame);
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.candidates, 0);
}

}  // namespace
}  // namespace desslam::tracking
