// Smooth hand-held-like camera paths for the default synthetic room (sim/synthetic_scene.hpp).
//
// Both paths stay in the free middle of a room of at least 6 x 4 x 3 m (|x| <= 1.3 m,
// -1.05 <= y <= -0.15 m, 1.25 <= z <= 1.55 m) and look roughly along +y (towards the far wall),
// pitched down ~12 degrees, with yaw/pitch/roll that keep changing. Speeds ~0.2-0.45 m/s and
// angular rates <= 25 deg/s, as a hand-held Kinect in the TUM/Bonn sequences.
#pragma once

#include "core/trajectory.hpp"

namespace desslam::sim {

// Open path: moves one way along x for the first ~10 s (longer paths turn back smoothly, but
// never return exactly to the start). Frame i is at t0 + i / fps.
Trajectory sweepPath(int frames, double fps, Timestamp t0 = 1000.0);

// Closed path: an ellipse travelled `laps` times; the pose at frame k * frames / laps equals the
// start pose (exactly periodic, so a loop closure must find the start again). The ellipse size
// follows the lap time to keep ~0.32 m/s (laps of ~3-16 s; longer laps move slower);
// rotation amplitudes shrink for short laps.
Trajectory loopPath(int frames, double fps, int laps, Timestamp t0 = 1000.0);

// Camera-to-world rotation looking along world +y (z up) turned by yaw (about world z,
// positive = left), pitch (positive = up) and roll (about the optical axis), radians.
Mat3 lookRotation(double yaw, double pitch, double roll);

}  // namespace desslam::sim
