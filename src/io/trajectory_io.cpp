#include "io/trajectory_io.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "io/data_lines.hpp"

namespace desslam::io {

Trajectory readTumTrajectory(const std::filesystem::path& path, std::vector<std::string>* warnings) {
  std::ifstream in(path);
  if (!in)
    throw InputError("cannot open trajectory file " + path.string() +
                     ": check the path (TUM format: timestamp tx ty tz qx qy qz qw)");
  return parseTumTrajectory(in, path.string(), warnings);
}

Trajectory parseTumTrajectory(std::istream& in, const std::string& name, std::vector<std::string>* warnings) {
  static constexpr const char* kColumns[] = {"timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};
  constexpr double kMaxPosition = 1e6;  // metres; anything beyond is a broken file, and squares overflow
  Trajectory trajectory;
  std::vector<int> lines;  // line of each pose, for the tie warnings
  forEachDataLine(in, [&](std::string& line, int line_number) {
    for (char& c : line)
      if (c == ',') c = ' ';  // tolerate comma-separated files
    const std::string where = name + ":" + std::to_string(line_number);
    std::istringstream fields(line);
    double v[8];
    std::string tokens[8];
    for (int k = 0; k < 8; ++k) {
      std::string& token = tokens[k];
      if (!(fields >> token))
        throw InputError(where + ": expected 8 numbers 'timestamp tx ty tz qx qy qz qw', got " + std::to_string(k));
      // strtod reads nan and inf too, so that they are named as such rather than "not a number".
      char* end = nullptr;
      errno = 0;
      v[k] = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0')
        throw InputError(where + ": " + kColumns[k] + " '" + token +
                         "' is not a number (expected 'timestamp tx ty tz qx qy qz qw')");
      if (!std::isfinite(v[k]) || errno == ERANGE)
        throw InputError(where + ": " + kColumns[k] + " is " + token + ", not a finite number: the pose is unusable");
    }
    for (int k = 1; k <= 3; ++k)
      if (std::abs(v[k]) > kMaxPosition)
        throw InputError(where + ": " + kColumns[k] + " = " + tokens[k] +
                         " m is beyond 1e6 m: not a camera position (broken file?)");
    const double t = v[0], tx = v[1], ty = v[2], tz = v[3], qx = v[4], qy = v[5], qz = v[6], qw = v[7];
    const double qnorm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
    if (!(qnorm > 1e-6) || !std::isfinite(qnorm))
      throw InputError(where + ": quaternion has zero or non-finite norm");
    trajectory.push_back({t, SE3(Quat(qw / qnorm, qx / qnorm, qy / qnorm, qz / qnorm), Vec3(tx, ty, tz))});
    lines.push_back(line_number);
  });
  if (warnings != nullptr) {
    std::vector<std::size_t> order(trajectory.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return trajectory[a].timestamp < trajectory[b].timestamp; });
    std::size_t ties = 0;
    for (std::size_t k = 1; k < order.size(); ++k) {
      if (trajectory[order[k]].timestamp != trajectory[order[k - 1]].timestamp) continue;
      if (++ties > 10) continue;
      char stamp[64];
      std::snprintf(stamp, sizeof(stamp), "%.6f", trajectory[order[k]].timestamp);
      warnings->push_back(name + ": lines " + std::to_string(lines[order[k - 1]]) + " and " +
                          std::to_string(lines[order[k]]) + " have the same timestamp " + stamp +
                          " (a tie: which pose is used for that time is arbitrary)");
    }
    if (ties > 10) warnings->push_back(name + ": " + std::to_string(ties - 10) + " more timestamp ties");
  }
  return trajectory;
}

namespace {
constexpr int kAtlasColumns = 10;

std::vector<std::string> splitFields(std::string line) {
  for (char& c : line)
    if (c == ',') c = ' ';
  std::istringstream in(line);
  std::vector<std::string> fields;
  for (std::string f; in >> f;) fields.push_back(f);
  return fields;
}
}  // namespace

AtlasTrajectory readAtlasTrajectory(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in)
    throw InputError("cannot open trajectory file " + path.string() +
                     ": check the path (CameraTrajectory_all.txt format: timestamp tx ty tz qx qy qz qw map world_map)");
  return parseAtlasTrajectory(in, path.string());
}

AtlasTrajectory parseAtlasTrajectory(std::istream& in, const std::string& name) {
  // The pose columns go through the TUM parser (the same checks and messages); other lines stay as
  // empty lines so that its messages name the file's own line numbers.
  std::string poses;
  std::vector<std::pair<int, int>> maps;
  int last_line = 0;
  forEachDataLine(in, [&](std::string& line, int line_number) {
    poses.append(static_cast<size_t>(line_number - last_line - 1), '\n');
    last_line = line_number;
    const std::vector<std::string> fields = splitFields(line);
    const std::string where = name + ":" + std::to_string(line_number);
    if (fields.size() != kAtlasColumns)
      throw InputError(where + ": expected " + std::to_string(kAtlasColumns) +
                       " columns 'timestamp tx ty tz qx qy qz qw map world_map' (as CameraTrajectory_all.txt has), got " +
                       std::to_string(fields.size()));
    int ids[2];
    for (int k = 0; k < 2; ++k) {
      const std::string& token = fields[8 + k];
      char* end = nullptr;
      errno = 0;
      const long v = std::strtol(token.c_str(), &end, 10);
      if (end == token.c_str() || *end != '\0' || errno == ERANGE || v < 0 || v > 1000000)
        throw InputError(where + ": " + (k == 0 ? "map" : "world_map") + " '" + token +
                         "' is not a map id (a non-negative integer)");
      ids[k] = static_cast<int>(v);
    }
    for (int k = 0; k < 8; ++k) poses += fields[k] + (k < 7 ? " " : "\n");
    maps.emplace_back(ids[0], ids[1]);
  });
  std::istringstream pose_text(poses);
  const Trajectory trajectory = parseTumTrajectory(pose_text, name);
  AtlasTrajectory atlas;
  atlas.reserve(trajectory.size());
  for (size_t i = 0; i < trajectory.size(); ++i)
    atlas.push_back({trajectory[i].timestamp, trajectory[i].T_w_c, maps[i].first, maps[i].second});
  return atlas;
}

bool hasAtlasColumns(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::optional<size_t> columns;
  forEachDataLine(in, [&](std::string& line, int) {
    if (!columns) columns = splitFields(line).size();
  });
  return columns == static_cast<size_t>(kAtlasColumns);
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
