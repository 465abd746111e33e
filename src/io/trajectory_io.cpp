#include "io/trajectory_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>

#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace desslam::io {

Trajectory readTumTrajectory(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in)
    throw InputError("cannot open trajectory file " + path.string() +
                     ": check the path (TUM format: timestamp tx ty tz qx qy qz qw)");
  Trajectory trajectory;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    for (char& c : line)
      if (c == ',') c = ' ';  // tolerate comma-separated files
    std::istringstream fields(line);
    double t, tx, ty, tz, qx, qy, qz, qw;
    if (!(fields >> t >> tx >> ty >> tz >> qx >> qy >> qz >> qw))
      throw InputError(path.string() + ":" + std::to_string(line_number) +
                       ": expected 8 numbers 'timestamp tx ty tz qx qy qz qw'");
    const double qnorm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
    if (!(qnorm > 1e-6) || !std::isfinite(qnorm))
      throw InputError(path.string() + ":" + std::to_string(line_number) + ": quaternion has zero or non-finite norm");
    trajectory.push_back({t, SE3(Quat(qw, qx, qy, qz), Vec3(tx, ty, tz))});
  }
  return trajectory;
}

namespace {
// The trajectory writers create the folder (the dense-map writers do not).
void createFolderOf(const std::filesystem::path& path) {
  if (!path.has_parent_path()) return;
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  if (ec)
    throw OutputError("cannot write trajectory file " + path.string() + ": cannot create folder " +
                      path.parent_path().string() + ": " + ec.message());
}

// TUM's eight columns (no line end).
void appendPose(std::string& out, Timestamp timestamp, const SE3& T_w_c) {
  const Quat& q = T_w_c.quaternion();
  const Vec3& t = T_w_c.translation();
  char line[256];
  const int n = std::snprintf(line, sizeof(line), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f", timestamp, t.x(), t.y(),
                              t.z(), q.x(), q.y(), q.z(), q.w());
  out.append(line, static_cast<size_t>(std::max(0, std::min(n, static_cast<int>(sizeof(line)) - 1))));
}
}  // namespace

// Both are written through writeFileAtomically (core/atomic_file.hpp): a temporary file renamed
// onto the target, so an interrupted run or a full disk never leaves half a trajectory.
void writeTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  std::string text = "# timestamp tx ty tz qx qy qz qw (world-from-camera)\n";
  text.reserve(text.size() + trajectory.size() * 100);
  for (const auto& sp : trajectory) {
    appendPose(text, sp.timestamp, sp.T_w_c);
    text += '\n';
  }
  createFolderOf(path);
  writeFileAtomically(path, text, "trajectory file");
}

void writeAtlasTrajectory(const std::filesystem::path& path, const AtlasTrajectory& trajectory) {
  std::string text =
      "# timestamp tx ty tz qx qy qz qw map world_map (world-from-camera in world_map's world;\n"
      "# map: the atlas map the frame was tracked in, world_map: the map it was merged into or itself)\n";
  text.reserve(text.size() + trajectory.size() * 110);
  for (const auto& sp : trajectory) {
    appendPose(text, sp.timestamp, sp.T_w_c);
    text += ' ' + std::to_string(sp.map) + ' ' + std::to_string(sp.world_map) + '\n';
  }
  createFolderOf(path);
  writeFileAtomically(path, text, "trajectory file");
}

}  // namespace desslam::io
