#include "sim/camera_path.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/option_fields.hpp"

namespace desslam::sim {

namespace {

constexpr double kTwoPi = 2.0 * 3.14159265358979323846;
constexpr double kBasePitch = -0.21;  // ~12 degrees down: floor in the lower part of the image

void checkArguments(const char* function, int frames, double fps) {
  requireThat(frames >= 1, function, "frames", "need at least one frame");
  requireThat(fps > 0 && std::isfinite(fps), function, "fps", "must be a positive frame rate");
}

}  // namespace

Mat3 lookRotation(double yaw, double pitch, double roll) {
  // Camera axes (x right, y down, z forward) for yaw = pitch = roll = 0: x -> +x, y -> -z, z -> +y.
  Mat3 base;
  base << 1, 0, 0,  //
      0, 0, 1,      //
      0, -1, 0;
  const Eigen::AngleAxisd R_yaw(yaw, Vec3::UnitZ()), R_pitch(pitch, Vec3::UnitX()), R_roll(roll, Vec3::UnitZ());
  return (R_yaw * R_pitch).toRotationMatrix() * base * R_roll.toRotationMatrix();
}

Trajectory sweepPath(int frames, double fps, Timestamp t0) {
  checkArguments("sweepPath", frames, fps);
  Trajectory path;
  path.reserve(frames);
  for (int i = 0; i < frames; ++i) {
    const double t = i / fps;
    // Incommensurate frequencies: x carries the sweep, the rest keeps the motion hand-held.
    const Vec3 position(1.25 * std::sin(0.22 * t), -0.6 + 0.3 * std::sin(0.9 * t), 1.4 + 0.12 * std::sin(0.9 * t + 0.5));
    const double yaw = 0.45 * std::sin(0.6 * t) - 0.25 * std::sin(0.22 * t);
    const double pitch = kBasePitch + 0.08 * std::sin(0.75 * t + 1.0);
    const double roll = 0.05 * std::sin(0.8 * t + 2.0);
    path.push_back({t0 + t, SE3(lookRotation(yaw, pitch, roll), position)});
  }
  return path;
}

Trajectory loopPath(int frames, double fps, int laps, Timestamp t0) {
  checkArguments("loopPath", frames, fps);
  requireThat(laps >= 1 && laps <= frames, "loopPath", "laps", "need 1 <= laps <= frames");
  const double lap_time = frames / (fps * laps);
  const double omega = kTwoPi / lap_time;
  // Radius for ~0.32 m/s around the ellipse (axes 1.3 r and 0.5 r), kept inside the free middle.
  const double r = std::clamp(0.32 / omega, 0.15, 0.8);
  // Rotation amplitudes bounded by rate budgets (rad/s) so short laps do not spin fast.
  const double yaw_amplitude = std::min(0.4, 0.35 / omega);
  const double pitch_amplitude = std::min(0.08, 0.15 / (2 * omega));
  const double roll_amplitude = std::min(0.05, 0.1 / omega);
  Trajectory path;
  path.reserve(frames);
  for (int i = 0; i < frames; ++i) {
    const double t = i / fps;
    const double phase = omega * t;
    const Vec3 position(1.3 * r * std::sin(phase), -0.6 + 0.5 * r * std::cos(phase),
                        1.4 + 0.08 * std::sin(2 * phase));
    const double yaw = yaw_amplitude * std::sin(phase);
    const double pitch = kBasePitch + pitch_amplitude * std::sin(2 * phase);
    const double roll = roll_amplitude * std::sin(phase + 0.7);
    path.push_back({t0 + t, SE3(lookRotation(yaw, pitch, roll), position)});
  }
  return path;
}

}  // namespace desslam::sim
