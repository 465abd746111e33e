// writeSequence: a synthetic sequence on disk in the TUM RGB-D layout.
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "sim/synthetic_scene.hpp"

namespace desslam::sim {

namespace {

std::string stampName(double timestamp) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.6f.png", timestamp);
  return buffer;
}

void writeImage(const std::filesystem::path& path, const cv::Mat& image) {
  // Fast PNG compression: sequences are written by tests, speed beats file size.
  if (!cv::imwrite(path.string(), image, {cv::IMWRITE_PNG_COMPRESSION, 1}))
    throw InputError("writeSequence: cannot write image " + path.string() + ": check the folder permissions");
}

std::ofstream openList(const std::filesystem::path& path, const std::string& header) {
  std::ofstream out(path);
  if (!out) throw InputError("writeSequence: cannot write " + path.string() + ": check the folder permissions");
  out << header;
  return out;
}

}  // namespace

void writeSequence(const std::filesystem::path& dir, const SyntheticScene& scene, const Trajectory& path,
                   const CameraOptions& camera, bool write_masks) {
  const CameraOptions& rendered = scene.camera();
  if (camera.width != rendered.width || camera.height != rendered.height)
    throw InputError("writeSequence: camera is " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                     " but the scene renders " + std::to_string(rendered.width) + "x" +
                     std::to_string(rendered.height) + "; pass the scene's camera");
  if (!(camera.depth_factor > 0)) throw InputError("writeSequence: camera.depth_factor must be positive");
  std::error_code error;
  for (const char* sub : {"rgb", "depth", "masks"}) {
    if (std::string(sub) == "masks" && !write_masks) continue;
    std::filesystem::create_directories(dir / sub, error);
    if (error) throw InputError("writeSequence: cannot create " + (dir / sub).string() + ": " + error.message());
  }

  auto rgb_list = openList(dir / "rgb.txt", "# color images (synthetic)\n# timestamp filename\n");
  auto depth_list = openList(dir / "depth.txt", "# depth images (synthetic), 16-bit PNG, metres * " +
                                                    std::to_string(camera.depth_factor) + "\n# timestamp filename\n");
  auto truth = openList(dir / "groundtruth.txt", "# ground truth trajectory (synthetic, world-from-camera)\n"
                                                 "# timestamp tx ty tz qx qy qz qw\n");
  char line[256];
  for (const auto& pose : path) {
    const RenderedFrame frame = scene.render(pose.T_w_c, pose.timestamp);
    const std::string rgb_name = stampName(pose.timestamp);
    const std::string depth_name = stampName(pose.timestamp + kDepthTimeOffset);
    writeImage(dir / "rgb" / rgb_name, frame.bgr);
    cv::Mat depth_raw;
    // saturate_cast rounds and clamps at 65535; 0 (no reading) stays 0.
    frame.depth.convertTo(depth_raw, CV_16U, camera.depth_factor);
    writeImage(dir / "depth" / depth_name, depth_raw);
    if (write_masks) writeImage(dir / "masks" / rgb_name, frame.dynamic_mask);

    std::snprintf(line, sizeof(line), "%.6f", pose.timestamp);
    rgb_list << line << " rgb/" << rgb_name << "\n";
    std::snprintf(line, sizeof(line), "%.6f", pose.timestamp + kDepthTimeOffset);
    depth_list << line << " depth/" << depth_name << "\n";
    const Quat& q = pose.T_w_c.quaternion();
    const Vec3& t = pose.T_w_c.translation();
    std::snprintf(line, sizeof(line), "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", pose.timestamp, t.x(), t.y(), t.z(),
                  q.x(), q.y(), q.z(), q.w());
    truth << line;
  }
  if (!rgb_list || !depth_list || !truth) throw InputError("writeSequence: failed writing the lists in " + dir.string());
}

}  // namespace desslam::sim
