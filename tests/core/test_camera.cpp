// PinholeCamera: projection round trip, the distortion model against OpenCV's undistortion
// (TUM fr1 values from config/tum_fr1.yaml), and the undistorted image bounds.
#include "core/camera.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.hpp"

namespace desslam {
namespace {

// config/tum_fr1.yaml (TUM's published freiburg1 RGB calibration).
CameraOptions tumFr1() {
  CameraOptions c;
  c.fx = 517.306408;
  c.fy = 516.469215;
  c.cx = 318.643040;
  c.cy = 255.313989;
  c.width = 640;
  c.height = 480;
  c.distortion = {0.262383, -0.953104, -0.005358, 0.002628, 1.163314};
  c.depth_factor = 5000;
  return c;
}

CameraOptions pinhole() {
  CameraOptions c = tumFr1();
  c.distortion = {0, 0, 0, 0, 0};
  return c;
}

TEST(PinholeCamera, ProjectBackProjectRoundTrip) {
  const PinholeCamera camera(tumFr1());
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0, 640), v(0, 480), z(0.1, 10.0);
  for (int i = 0; i < 500; ++i) {
    const Vec2 uv(u(rng), v(rng));
    const double depth = z(rng);
    const Vec3 p_c = camera.backProject(uv, depth);
    EXPECT_DOUBLE_EQ(p_c.z(), depth);
    EXPECT_LT((camera.project(p_c) - uv).norm(), 1e-9);
  }
  // And point -> pixel -> point.
  const Vec3 p_c(0.3, -0.2, 1.7);
  EXPECT_LT((camera.backProject(camera.project(p_c), p_c.z()) - p_c).norm(), 1e-12);
}

TEST(PinholeCamera, PrincipalPointIsTheOpticalAxis) {
  const PinholeCamera camera(tumFr1());
  const Vec2 uv = camera.project(Vec3(0, 0, 2.0));
  EXPECT_DOUBLE_EQ(uv.x(), 318.643040);
  EXPECT_DOUBLE_EQ(uv.y(), 255.313989);
  // One focal length to the side at unit depth = one metre per fx pixels.
  EXPECT_NEAR(camera.project(Vec3(1.0, 0, 1.0)).x() - uv.x(), 517.306408, 1e-9);
}

TEST(PinholeCamera, KAndDistortionCoefficientsCarryTheOptions) {
  const PinholeCamera camera(tumFr1());
  const cv::Mat K = camera.K();
  ASSERT_EQ(K.type(), CV_64F);
  EXPECT_DOUBLE_EQ(K.at<double>(0, 0), 517.306408);
  EXPECT_DOUBLE_EQ(K.at<double>(1, 1), 516.469215);
  EXPECT_DOUBLE_EQ(K.at<double>(0, 2), 318.643040);
  EXPECT_DOUBLE_EQ(K.at<double>(1, 2), 255.313989);
  EXPECT_DOUBLE_EQ(K.at<double>(2, 2), 1.0);
  const cv::Mat d = camera.distortionCoeffs();
  ASSERT_EQ(d.total(), 5u);
  EXPECT_DOUBLE_EQ(d.at<double>(0, 0), 0.262383);
  EXPECT_DOUBLE_EQ(d.at<double>(0, 4), 1.163314);
  EXPECT_TRUE(camera.hasDistortion());
  EXPECT_FALSE(PinholeCamera(pinhole()).hasDistortion());
}

// Every ideal pixel whose raw (distorted) position lies in the raw image must come back from
// undistort() to within 0.01 px: features are undistorted with it and projected with the model.
TEST(PinholeCamera, UndistortInvertsDistortOverTheImage) {
  const PinholeCamera camera(tumFr1());
  std::vector<cv::Point2f> raw;
  std::vector<Vec2> ideal;
  for (double v = camera.minY(); v <= camera.maxY(); v += 4.0) {
    for (double u = camera.minX(); u <= camera.maxX(); u += 4.0) {
      const Vec2 uv(u, v);
      const Vec2 d = camera.distort(uv);
      if (d.x() < 0 || d.x() > 640 || d.y() < 0 || d.y() > 480) continue;
      ideal.push_back(uv);
      raw.emplace_back(static_cast<float>(d.x()), static_cast<float>(d.y()));
    }
  }
  ASSERT_GT(raw.size(), 15000u);
  const std::vector<cv::Point2f> back = camera.undistort(raw);
  ASSERT_EQ(back.size(), raw.size());
  double worst = 0;
  Vec2 worst_at(0, 0);
  for (size_t i = 0; i < back.size(); ++i) {
    const double err = (Vec2(back[i].x, back[i].y) - ideal[i]).norm();
    if (err > worst) {
      worst = err;
      worst_at = ideal[i];
    }
  }
  EXPECT_LT(worst, 0.01) << "largest undistort(distort(uv)) error " << worst << " px at ideal pixel ("
                         << worst_at.x() << ", " << worst_at.y() << ")";
}

TEST(PinholeCamera, RawImageCornersUndistortToTheBounds) {
  const PinholeCamera camera(tumFr1());
  EXPECT_LT(camera.minX(), camera.cx());
  EXPECT_GT(camera.maxX(), camera.cx());
  EXPECT_LT(camera.minY(), camera.cy());
  EXPECT_GT(camera.maxY(), camera.cy());
  // Undistorted raw corners distort back onto the raw corners.
  const std::vector<cv::Point2f> raw{{0, 0}, {640, 0}, {0, 480}, {640, 480}};
  const auto ideal = camera.undistort(raw);
  ASSERT_EQ(ideal.size(), raw.size());
  for (size_t i = 0; i < raw.size(); ++i) {
    const Vec2 back = camera.distort(Vec2(ideal[i].x, ideal[i].y));
    EXPECT_LT((back - Vec2(raw[i].x, raw[i].y)).norm(), 0.01) << "raw corner " << raw[i];
  }
  // The bounds are spanned by those corners.
  EXPECT_FLOAT_EQ(static_cast<float>(camera.minX()), std::min(ideal[0].x, ideal[2].x));
  EXPECT_FLOAT_EQ(static_cast<float>(camera.maxY()), std::max(ideal[2].y, ideal[3].y));
}

TEST(PinholeCamera, InImageBoundsWithoutDistortion) {
  const PinholeCamera camera(pinhole());
  EXPECT_EQ(camera.minX(), 0.0);
  EXPECT_EQ(camera.maxX(), 640.0);
  EXPECT_EQ(camera.minY(), 0.0);
  EXPECT_EQ(camera.maxY(), 480.0);
  EXPECT_TRUE(camera.inImage({0.0, 0.0}));
  EXPECT_TRUE(camera.inImage({639.999, 479.999}));
  EXPECT_TRUE(camera.inImage({320, 240}));
  EXPECT_FALSE(camera.inImage({640.0, 240}));  // upper bound is exclusive
  EXPECT_FALSE(camera.inImage({320, 480.0}));
  EXPECT_FALSE(camera.inImage({-0.001, 240}));
  EXPECT_FALSE(camera.inImage({320, -0.001}));
  EXPECT_FALSE(camera.inImage({1e6, 1e6}));
}

TEST(PinholeCamera, InImageFollowsTheUndistortedBounds) {
  const PinholeCamera camera(tumFr1());
  EXPECT_TRUE(camera.inImage({camera.cx(), camera.cy()}));
  EXPECT_TRUE(camera.inImage({camera.minX(), camera.minY()}));
  EXPECT_FALSE(camera.inImage({camera.maxX(), camera.cy()}));
  EXPECT_FALSE(camera.inImage({camera.cx(), camera.maxY()}));
  EXPECT_FALSE(camera.inImage({camera.minX() - 0.01, camera.cy()}));
  EXPECT_FALSE(camera.inImage({camera.cx(), camera.minY() - 0.01}));
}

TEST(PinholeCamera, NoDistortionMeansIdentityUndistortAndDistort) {
  const PinholeCamera camera(pinhole());
  const std::vector<cv::Point2f> pts{{0, 0}, {100.25f, 300.5f}, {639, 479}};
  const auto out = camera.undistort(pts);
  ASSERT_EQ(out.size(), pts.size());
  for (size_t i = 0; i < pts.size(); ++i) EXPECT_EQ(out[i], pts[i]);
  EXPECT_EQ(camera.distort({12.5, 33.25}), Vec2(12.5, 33.25));
  EXPECT_TRUE(camera.undistort({}).empty());
}

TEST(PinholeCamera, DistortionIsZeroAtThePrincipalPoint) {
  const PinholeCamera camera(tumFr1());
  const Vec2 c(camera.cx(), camera.cy());
  EXPECT_LT((camera.distort(c) - c).norm(), 1e-12);
}

TEST(PinholeCamera, InvalidOptionsAreRejectedWithTheKey) {
  CameraOptions bad = tumFr1();
  bad.fx = 0;
  try {
    PinholeCamera camera(bad);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("camera.fx"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace desslam
