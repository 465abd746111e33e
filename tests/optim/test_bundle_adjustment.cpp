#include <thread>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "optim/bundle_adjustment.hpp"
#include "optim/synthetic_scene.hpp"

namespace desslam::optim {
namespace {

using test::rotationErrorDeg;
using test::translationError;

struct BaScene {
  std::vector<BaKeyframe> truth_keyframes;
  std::vector<BaPoint> truth_points;
  std::vector<BaKeyframe> keyframes;  // perturbed start (keyframe 0 fixed at the truth)
  std::vector<BaPoint> points;        // perturbed start
  std::vector<BaObservation> observations;
  std::vector<bool> injected_outlier;
};

// A camera sliding sideways past a box of points 2-5 m ahead: 0.5 px noise, 70% of the
// observations with depth, `outlier_share` of them moved 20-100 px.
BaScene makeScene(const PinholeCamera& cam, int num_keyframes, int num_points, double outlier_share,
                  unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1), bx(-1.5, 3.0), by(-1.2, 1.2), bz(2.0, 5.0);
  std::uniform_real_distribution<double> offset(20, 100), angle(0, 2 * M_PI);
  std::normal_distribution<double> point_noise(0, 0.03);
  BaScene s;
  for (int k = 0; k < num_keyframes; ++k) {
    const Vec3 centre(0.1 * k, 0.02 * std::sin(k), 0.05 * std::cos(0.5 * k));
    const Mat3 R_w_c = so3Exp(Vec3(0.02 * k, 0.03 * std::sin(0.7 * k), 0.01 * k));
    s.truth_keyframes.push_back({SE3(R_w_c, centre).inverse(), k == 0});
  }
  for (int p = 0; p < num_points; ++p) s.truth_points.push_back({Vec3(bx(rng), by(rng), bz(rng))});
  for (int k = 0; k < num_keyframes; ++k) {
    for (int p = 0; p < num_points; ++p) {
      const Vec3 p_c = s.truth_keyframes[k].T_c_w * s.truth_points[p].p_w;
      if (p_c.z() < 0.5 || !cam.inImage(cam.project(p_c))) continue;
      BaObservation o{k, p, test::observe(cam, p_c, unit(rng) < 0.7, 0.5, rng)};
      const bool gross = unit(rng) < outlier_share;
      if (gross) {
        const double a = angle(rng);
        o.obs.uv += offset(rng) * Vec2(std::cos(a), std::sin(a));
      }
      s.observations.push_back(o);
      s.injected_outlier.push_back(gross);
    }
  }
  s.keyframes = s.truth_keyframes;
  for (std::size_t k = 1; k < s.keyframes.size(); ++k)
    s.keyframes[k].T_c_w = test::perturb(s.keyframes[k].T_c_w, rng, 0.03, 1.0 * M_PI / 180.0);
  s.points = s.truth_points;
  for (auto& p : s.points) p.p_w += Vec3(point_noise(rng), point_noise(rng), point_noise(rng));
  return s;
}

double medianPointError(const BaScene& s) {
  std::vector<double> e;
  for (std::size_t p = 0; p < s.points.size(); ++p) e.push_back((s.points[p].p_w - s.truth_points[p].p_w).norm());
  std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
  return e[e.size() / 2];
}

TEST(BundleAdjust, ConvergesToTruthAndFlagsInjectedOutliers) {
  const auto cam = test::tumCamera();
  BaScene s = makeScene(cam, 10, 1000, 0.02, 17);
  const double start_point_error = medianPointError(s);

  ASSERT_TRUE(bundleAdjust(cam, s.keyframes, s.points, s.observations));

  EXPECT_EQ(translationError(s.keyframes[0].T_c_w, s.truth_keyframes[0].T_c_w), 0.0) << "fixed keyframe moved";
  for (std::size_t k = 1; k < s.keyframes.size(); ++k) {
    EXPECT_LT(translationError(s.keyframes[k].T_c_w, s.truth_keyframes[k].T_c_w), 0.003) << "keyframe " << k;
    EXPECT_LT(rotationErrorDeg(s.keyframes[k].T_c_w, s.truth_keyframes[k].T_c_w), 0.05) << "keyframe " << k;
  }
  EXPECT_LT(medianPointError(s), 0.005);
  EXPECT_LT(medianPointError(s), start_point_error / 5);

  int injected = 0, missed = 0, false_flags = 0, clean = 0;
  for (std::size_t i = 0; i < s.observations.size(); ++i) {
    if (s.injected_outlier[i]) {
      ++injected;
      if (!s.observations[i].outlier) ++missed;
    } else {
      ++clean;
      if (s.observations[i].outlier) ++false_flags;
    }
  }
  ASSERT_GT(injected, 50);
  EXPECT_EQ(missed, 0);
  // 0.5 px noise with unit information: the 95% threshold is far out in the tail.
  EXPECT_LT(false_flags, clean / 100 + 1);
}

TEST(BundleAdjust, SinglePassAlsoFlagsOutliers) {
  const auto cam = test::tumCamera();
  BaScene s = makeScene(cam, 5, 300, 0.05, 3);
  BundleAdjustmentOptions options;
  options.second_pass_without_outliers = false;
  ASSERT_TRUE(bundleAdjust(cam, s.keyframes, s.points, s.observations, options));
  for (std::size_t i = 0; i < s.observations.size(); ++i) {
    if (s.injected_outlier[i]) EXPECT_TRUE(s.observations[i].outlier) << "observation " << i;
  }
  for (std::size_t k = 1; k < s.keyframes.size(); ++k)
    EXPECT_LT(translationError(s.keyframes[k].T_c_w, s.truth_keyframes[k].T_c_w), 0.005) << "keyframe " << k;
}

TEST(BundleAdjust, RaisedAbortFlagReturnsFalseWithoutChanges) {
  const auto cam = test::tumCamera();
  BaScene s = makeScene(cam, 4, 200, 0.0, 5);
  const BaScene before = s;
  std::atomic<bool> abort{true};
  EXPECT_FALSE(bundleAdjust(cam, s.keyframes, s.points, s.observations, {}, &abort));
  for (std::size_t k = 0; k < s.keyframes.size(); ++k)
    EXPECT_EQ(translationError(s.keyframes[k].T_c_w, before.keyframes[k].T_c_w), 0.0);
  for (std::size_t p = 0; p < s.points.size(); ++p) EXPECT_EQ(s.points[p].p_w, before.points[p].p_w);
}

// The flag raised while BA runs (as local mapping does when a keyframe arrives): it stops and
// reports it, and what it wrote back is no worse than the start.
TEST(BundleAdjust, AbortDuringSolveStopsEarly) {
  const auto cam = test::tumCamera();
  BaScene s = makeScene(cam, 15, 3000, 0.0, 9);
  const double start_point_error = medianPointError(s);
  std::atomic<bool> abort{false};
  std::thread raiser([&abort] { abort.store(true); });
  const bool completed = bundleAdjust(cam, s.keyframes, s.points, s.observations, {}, &abort);
  raiser.join();
  EXPECT_FALSE(completed);
  EXPECT_LE(medianPointError(s), start_point_error);
}

TEST(BundleAdjust, RejectsBadIndices) {
  const auto cam = test::tumCamera();
  BaScene s = makeScene(cam, 2, 20, 0.0, 5);
  s.observations.push_back({5, 0, Observation{}});
  EXPECT_THROW(bundleAdjust(cam, s.keyframes, s.points, s.observations), InputError);
  s.observations.back() = {0, 99, Observation{}};
  EXPECT_THROW(bundleAdjust(cam, s.keyframes, s.points, s.observations), InputError);
}

}  // namespace
}  // namespace desslam::optim
