// Synthetic cameras, points and noisy observations for the optimiser tests.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "optim/bundle_adjustment.hpp"
#include "optim/observation.hpp"
#include "optim/pose_optimizer.hpp"

namespace desslam::optim::test {

inline PinholeCamera tumCamera() {
  CameraOptions c;
  c.fx = 517.3;
  c.fy = 516.5;
  c.cx = 318.6;
  c.cy = 255.3;
  return PinholeCamera(c);
}

inline constexpr double kBf = 40.0;

inline SE3 perturb(const SE3& T, std::mt19937& rng, double translation_m, double rotation_rad) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Vec3 dt = Vec3(n(rng), n(rng), n(rng)).normalized() * translation_m;
  const Vec3 dr = Vec3(n(rng), n(rng), n(rng)).normalized() * rotation_rad;
  return SE3(so3Exp(dr), dt) * T;
}

// Observation of a camera-frame point with Gaussian pixel noise; the depth (if any) carries
// noise of the same size in the virtual right coordinate u_r = u - bf/d.
inline Observation observe(const PinholeCamera& cam, const Vec3& p_c, bool with_depth, double pixel_sigma,
                           std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, pixel_sigma);
  Observation o;
  o.uv = cam.project(p_c) + Vec2(n(rng), n(rng));
  if (with_depth) o.depth = kBf / (kBf / p_c.z() + n(rng));
  o.inv_sigma2 = 1.0;
  return o;
}

inline double translationError(const SE3& a, const SE3& b) { return (a.translation() - b.translation()).norm(); }
inline double rotationErrorDeg(const SE3& a, const SE3& b) { return (a * b.inverse()).rotationAngle() * 180.0 / M_PI; }

struct PoseScene {
  SE3 T_c_w_true;
  std::vector<PoseObservation> observations;
  std::vector<bool> injected_outlier;
};

// Points spread over the image at 1-4 m, `depth_share` of them with depth, pixel noise 1 px
// (unit information, so chi2 is chi2-distributed), `outlier_share` moved 20-100 px away.
inline PoseScene makePoseScene(const PinholeCamera& cam, int n, double depth_share, double outlier_share,
                                unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, cam.width()), v(0, cam.height()), z(1.0, 4.0), unit(0, 1);
  std::uniform_real_distribution<double> offset(20, 100), angle(0, 2 * M_PI);
  PoseScene s;
  s.T_c_w_true = test::perturb(SE3(), rng, 0.5, 0.5);
  const SE3 T_w_c = s.T_c_w_true.inverse();
  for (int i = 0; i < n; ++i) {
    const Vec3 p_c = cam.backProject(Vec2(u(rng), v(rng)), z(rng));
    PoseObservation po;
    po.obs = test::observe(cam, p_c, unit(rng) < depth_share, 1.0, rng);
    po.point_w = T_w_c * p_c;
    const bool gross = unit(rng) < outlier_share;
    if (gross) {
      const double a = angle(rng);
      po.obs.uv += offset(rng) * Vec2(std::cos(a), std::sin(a));
    }
    s.observations.push_back(po);
    s.injected_outlier.push_back(gross);
  }
  return s;
}

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
inline BaScene makeBaScene(const PinholeCamera& cam, int num_keyframes, int num_points, double outlier_share,
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

// How the optimiser's outlier flags compare with the outliers a scene injected.
struct OutlierTally {
  int injected = 0, missed = 0, clean = 0, false_flags = 0;
};
template <class Observations>
OutlierTally tallyOutliers(const Observations& observations, const std::vector<bool>& injected_outlier) {
  OutlierTally t;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (injected_outlier[i]) {
      ++t.injected;
      if (!observations[i].outlier) ++t.missed;
    } else {
      ++t.clean;
      if (observations[i].outlier) ++t.false_flags;
    }
  }
  return t;
}

}  // namespace desslam::optim::test
