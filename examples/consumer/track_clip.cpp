// Tracks a TUM RGB-D folder (rgb.txt, depth.txt, rgb/, depth/) through the installed DeS-SLAM
// library and prints how many frames got a pose.
//
//   track_clip <sequence folder> <camera preset> [section.key=value ...]
//   e.g. track_clip fr1_xyz tum_fr1 dense.enabled=false
//
// Exit codes: 0 tracked (whatever the share of frames), 1 an error (printed), 77 the sequence
// folder is missing (nothing to track: the test suite reports that as skipped).
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "desslam/desslam.hpp"

namespace fs = std::filesystem;

namespace {

constexpr int kExitMissingInput = 77;

struct Entry {
  double timestamp_s = 0;
  std::string file;
};

// "timestamp file" lines of a TUM list; '#' lines are comments.
std::vector<Entry> readList(const fs::path& list) {
  std::ifstream in(list);
  if (!in) throw std::runtime_error("cannot read " + list.string());
  std::vector<Entry> entries;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    Entry entry;
    if (fields >> entry.timestamp_s >> entry.file) entries.push_back(entry);
  }
  return entries;
}

// The depth image nearest in time to each colour image, within 20 ms (as TUM's associate.py).
std::vector<std::pair<Entry, Entry>> associate(const std::vector<Entry>& rgb, const std::vector<Entry>& depth) {
  std::vector<std::pair<Entry, Entry>> pairs;
  for (const Entry& colour : rgb) {
    const Entry* best = nullptr;
    for (const Entry& d : depth)
      if (best == nullptr || std::abs(d.timestamp_s - colour.timestamp_s) < std::abs(best->timestamp_s - colour.timestamp_s))
        best = &d;
    if (best != nullptr && std::abs(best->timestamp_s - colour.timestamp_s) < 0.02) pairs.emplace_back(colour, *best);
  }
  return pairs;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s <sequence folder> <camera preset> [section.key=value ...]\n", argv[0]);
    return 1;
  }
  const fs::path sequence = argv[1];
  if (!fs::is_regular_file(sequence / "rgb.txt")) {
    std::printf("SKIPPED: sequence %s not found (no rgb.txt there)\n", sequence.string().c_str());
    return kExitMissingInput;
  }
  try {
    std::printf("desslam %s, data folder %s\n", desslam::version().c_str(), desslam::dataDirectory().string().c_str());
    desslam::Config config = desslam::Config::fromPreset(argv[2]);
    for (int i = 3; i < argc; ++i) config.set(argv[i]);

    const auto frames = associate(readList(sequence / "rgb.txt"), readList(sequence / "depth.txt"));
    desslam::RunMode mode;
    mode.deterministic = true;  // every stage waits for the one before: the same result each run
    desslam::Slam slam(config, mode);
    size_t tracked = 0;
    for (const auto& [rgb, depth] : frames) {
      const cv::Mat bgr = cv::imread((sequence / rgb.file).string(), cv::IMREAD_COLOR);
      const cv::Mat depth_raw = cv::imread((sequence / depth.file).string(), cv::IMREAD_UNCHANGED);  // 16-bit
      if (bgr.empty() || depth_raw.empty()) throw std::runtime_error("cannot read the images of frame " + rgb.file);
      const desslam::TrackResult result = slam.track(rgb.timestamp_s, bgr, depth_raw, depth.timestamp_s - rgb.timestamp_s);
      if (result.hasPose()) ++tracked;
    }
    slam.finish();
    std::printf("tracked %zu of %zu frames\n", tracked, frames.size());
    std::printf("main map trajectory: %zu poses\n", slam.trajectory().size());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
