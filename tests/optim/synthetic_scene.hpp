// Synthetic cameras, points and noisy observations for the optimiser tests.
#pragma once

#include <random>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "optim/observation.hpp"

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

}  // namespace desslam::optim::test
