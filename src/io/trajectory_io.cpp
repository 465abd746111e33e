#include "io/trajectory_io.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

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
// Writes a temporary file then renames it, so an interrupted run never leaves half a file.
// write_rows(f) prints the header and rows.
template <class WriteRows>
void writeTrajectoryFile(const std::filesystem::path& path, WriteRows write_rows) {
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::FILE* f = std::fopen(tmp.c_str(), "w");
    if (f == nullptr) throw InputError("cannot write trajectory file " + path.string() + ": check permissions");
    write_rows(f);
    if (std::fclose(f) != 0) throw InputError("failed writing trajectory file " + tmp.string());
  }
  std::filesystem::rename(tmp, path);
}

// TUM's eight columns (no line end).
void printPose(std::FILE* f, Timestamp timestamp, const SE3& T_w_c) {
  const Quat& q = T_w_c.quaternion();
  const Vec3& t = T_w_c.translation();
  std::fprintf(f, "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f", timestamp, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
}
}  // namespace

void writeTumTrajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  writeTrajectoryFile(path, [&](std::FILE* f) {
    std::fprintf(f, "# timestamp tx ty tz qx qy qz qw (world-from-camera)\n");
    for (const auto& sp : trajectory) {
      printPose(f, sp.timestamp, sp.T_w_c);
      std::fprintf(f, "\n");
    }
  });
}

void writeAtlasTrajectory(const std::filesystem::path& path, const AtlasTrajectory& trajectory) {
  writeTrajectoryFile(path, [&](std::FILE* f) {
    std::fprintf(f, "# timestamp tx ty tz qx qy qz qw map world_map (world-from-camera in world_map's world;\n"
                    "# map: the atlas map the frame was tracked in, world_map: the map it was merged into or itself)\n");
    for (const auto& sp : trajectory) {
      printPose(f, sp.timestamp, sp.T_w_c);
      std::fprintf(f, " %d %d\n", sp.map, sp.world_map);
    }
  });
}

}  // namespace desslam::io
