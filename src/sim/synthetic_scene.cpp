#include "sim/synthetic_scene.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "core/camera.hpp"
#include "core/error.hpp"
#include "sim/texture.hpp"

namespace desslam::sim {

namespace {

using Box = Eigen::AlignedBox3d;

// Furniture stands in this band along the walls; the middle stays free for camera and mover.
constexpr double kMinBoxDepth = 0.3, kMaxBoxDepth = 0.7;

void requireField(bool ok, const char* field, const std::string& message) {
  requireThat(ok, "sim", field, message);
}

// Ray (o + t d) against an axis-aligned box, with inv_d = 1/d precomputed once per pixel:
// entry/exit distances and the axes they happen on (IEEE infinities handle d_i = 0).
struct SlabHit {
  double t_near = -std::numeric_limits<double>::infinity();
  double t_far = std::numeric_limits<double>::infinity();
  int axis_near = 0, axis_far = 0;
};

bool intersect(const Vec3& o, const Vec3& inv_d, const Box& box, SlabHit& hit) {
  hit = SlabHit{};
  for (int i = 0; i < 3; ++i) {
    double t1 = (box.min()[i] - o[i]) * inv_d[i], t2 = (box.max()[i] - o[i]) * inv_d[i];
    if (std::isnan(t1) || std::isnan(t2)) {  // d_i = 0 with o exactly on the slab plane
      if (o[i] < box.min()[i] || o[i] > box.max()[i]) return false;
      continue;
    }
    if (t1 > t2) std::swap(t1, t2);
    if (t1 > hit.t_near) { hit.t_near = t1; hit.axis_near = i; }
    if (t2 < hit.t_far) { hit.t_far = t2; hit.axis_far = i; }
    if (hit.t_near > hit.t_far) return false;
  }
  return true;
}

// Unsigned distance from p to the boundary of the box (inside or outside).
double distanceToBoxSurface(const Box& box, const Vec3& p) {
  if (box.contains(p)) return std::min((p - box.min()).minCoeff(), (box.max() - p).minCoeff());
  return std::sqrt(box.squaredExteriorDistance(p));
}

// Deterministic per-pixel Gaussian noise: counter-based, so parallel rows need no shared RNG.
std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

double gaussian(std::uint64_t key) {
  const std::uint64_t a = splitmix64(key), b = splitmix64(a);
  const double u1 = (static_cast<double>(a >> 11) + 0.5) * 0x1.0p-53;
  const double u2 = static_cast<double>(b >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * CV_PI * u2);
}

// A textured box: face 2*axis + side (side 0 at min, 1 at max) uses textures[that]; surface
// coordinates are the two other axes ((axis+1)%3, (axis+2)%3) measured from the box minimum.
struct TexturedBox {
  Box box;
  std::vector<cv::Mat> textures;
};

TexturedBox makeTexturedBox(const Box& box, double px_per_m, std::uint64_t seed) {
  TexturedBox out{box, {}};
  const Vec3 size = box.sizes();
  for (int face = 0; face < 6; ++face) {
    const int axis = face / 2;
    out.textures.push_back(makeSurfaceTexture(size[(axis + 1) % 3], size[(axis + 2) % 3], px_per_m,
                                              splitmix64(seed * 64 + face)));
  }
  return out;
}

cv::Vec3b sampleBilinear(const cv::Mat& texture, double x, double y) {
  x = std::clamp(x, 0.0, texture.cols - 1.001);
  y = std::clamp(y, 0.0, texture.rows - 1.001);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const double ax = x - x0, ay = y - y0;
  const cv::Vec3b* r0 = texture.ptr<cv::Vec3b>(y0) + x0;
  const cv::Vec3b* r1 = texture.ptr<cv::Vec3b>(y0 + 1) + x0;
  cv::Vec3b out;
  for (int c = 0; c < 3; ++c) {
    const double top = r0[0][c] + ax * (r0[1][c] - r0[0][c]);
    const double bottom = r1[0][c] + ax * (r1[1][c] - r1[0][c]);
    out[c] = cv::saturate_cast<uchar>(top + ay * (bottom - top));
  }
  return out;
}

}  // namespace

void SceneOptions::validate() const {
  requireField(room_size.x() >= 2.5 && room_size.y() >= 2.5 && room_size.z() >= 2.0 && room_size.allFinite(),
               "room_size", "room must be at least 2.5 x 2.5 x 2.0 m (x, y, z)");
  requireInRange("sim", "static_boxes", static_boxes, 0, 100);
  requireField((moving_size.array() > 0.0).all() && moving_size.z() < room_size.z(), "moving_size",
               "must be positive and lower than the room");
  requireField(moving_start.allFinite() && moving_velocity.allFinite(), "moving_start/moving_velocity",
               "must be finite numbers");
  const Vec3 free_half(room_size.x() / 2 - kMaxBoxDepth, room_size.y() / 2 - kMaxBoxDepth, 0);
  const Vec3 travel_half = free_half - moving_size / 2;
  requireField(!moving_object || (travel_half.x() > 0 && travel_half.y() > 0), "moving_size",
               "the moving object must fit in the free middle of the room (walls minus 0.7 m furniture band)");
  requireField(!moving_object || (std::abs(moving_start.x()) <= travel_half.x() &&
                                  std::abs(moving_start.y()) <= travel_half.y() && moving_start.z() >= 0 &&
                                  moving_start.z() + moving_size.z() <= room_size.z()),
               "moving_start", "bottom-centre must lie in the free middle of the room, on or above the floor");
  requireInRange("sim", "depth_noise_sigma", depth_noise_sigma, 0.0, 0.1);
  requireInRange("sim", "texture_px_per_m", texture_px_per_m, 16.0, 2048.0);
}

struct SyntheticScene::Impl {
  SceneOptions scene;
  CameraOptions camera;
  std::vector<cv::Vec2d> rays;  // per pixel, row-major: (x/z, y/z) of the undistorted ray
  TexturedBox room;             // seen from inside
  std::vector<TexturedBox> furniture;
  TexturedBox mover;            // box at moving_t0; moved by moverOffset(t)
  Box travel;                   // where the mover's bottom-centre may go

  Vec3 moverOffset(double time_s) const {
    // Straight line folded back at the travel limits (a triangle wave per axis).
    Vec3 p = scene.moving_start + scene.moving_velocity * (time_s - scene.moving_t0);
    for (int i = 0; i < 3; ++i) {
      const double lo = travel.min()[i], span = travel.max()[i] - lo;
      if (span <= 0) { p[i] = lo; continue; }
      double s = std::fmod(p[i] - lo, 2 * span);
      if (s < 0) s += 2 * span;
      p[i] = lo + (s > span ? 2 * span - s : s);
    }
    return p - scene.moving_start;
  }
  Box moverBox(double time_s) const {
    const Vec3 offset = moverOffset(time_s);
    return Box(mover.box.min() + offset, mover.box.max() + offset);
  }
};

SyntheticScene::SyntheticScene(const SceneOptions& scene, const CameraOptions& camera) {
  scene.validate();
  const PinholeCamera pinhole(camera);  // validates the camera
  auto impl = std::make_shared<Impl>();
  impl->scene = scene;
  impl->camera = camera;

  std::vector<cv::Point2f> raw;
  raw.reserve(static_cast<std::size_t>(camera.width) * camera.height);
  for (int v = 0; v < camera.height; ++v)
    for (int u = 0; u < camera.width; ++u) raw.emplace_back(float(u), float(v));
  impl->rays.reserve(raw.size());
  if (pinhole.hasDistortion()) {
    for (const auto& uv : pinhole.undistort(raw))
      impl->rays.emplace_back((uv.x - camera.cx) / camera.fx, (uv.y - camera.cy) / camera.fy);
  } else {
    for (const auto& uv : raw) impl->rays.emplace_back((uv.x - camera.cx) / camera.fx, (uv.y - camera.cy) / camera.fy);
  }

  const Vec3 half(scene.room_size.x() / 2, scene.room_size.y() / 2, 0);
  const double ppm = scene.texture_px_per_m;
  std::uint64_t surface_seed = splitmix64(scene.seed);
  impl->room = makeTexturedBox(Box(-half, half + Vec3(0, 0, scene.room_size.z())), ppm, surface_seed++);

  // Furniture: the far wall (+y, what the default paths face) gets the most boxes.
  cv::RNG rng(scene.seed);
  const int wall_order[] = {3, 0, 1, 3, 0, 1, 2, 3};  // 0: -x, 1: +x, 2: -y, 3: +y
  for (int k = 0; k < scene.static_boxes; ++k) {
    const int wall = wall_order[k % 8];
    const int normal_axis = wall / 2, along_axis = 1 - normal_axis;
    const double depth = rng.uniform(kMinBoxDepth, kMaxBoxDepth);
    const double length = scene.room_size[along_axis];
    const double width = std::min(rng.uniform(0.4, 1.2), 0.8 * length);
    const double height = std::min(rng.uniform(0.4, 2.0), scene.room_size.z() - 0.2);
    const double centre = rng.uniform(-(length - width) / 2, (length - width) / 2);
    Vec3 lo, hi;
    lo[along_axis] = centre - width / 2;
    hi[along_axis] = centre + width / 2;
    const double wall_pos = half[normal_axis];
    lo[normal_axis] = wall % 2 == 0 ? -wall_pos : wall_pos - depth;
    hi[normal_axis] = wall % 2 == 0 ? -wall_pos + depth : wall_pos;
    lo.z() = 0;
    hi.z() = height;
    impl->furniture.push_back(makeTexturedBox(Box(lo, hi), ppm, surface_seed++));
  }

  const Vec3 mover_half(scene.moving_size.x() / 2, scene.moving_size.y() / 2, 0);
  const Vec3 mover_lo = scene.moving_start - mover_half;
  impl->mover = makeTexturedBox(Box(mover_lo, mover_lo + scene.moving_size), ppm, surface_seed++);
  const Vec3 free_half(half.x() - kMaxBoxDepth, half.y() - kMaxBoxDepth, 0);
  impl->travel = Box(-free_half + mover_half, free_half - mover_half + Vec3(0, 0, scene.room_size.z() - scene.moving_size.z()));
  impl_ = std::move(impl);
}

const SceneOptions& SyntheticScene::options() const { return impl_->scene; }
const CameraOptions& SyntheticScene::camera() const { return impl_->camera; }

Eigen::AlignedBox3d SyntheticScene::movingObjectBox(double time_s) const {
  if (!impl_->scene.moving_object) return Box();
  return impl_->moverBox(time_s);
}

double SyntheticScene::distanceToStaticSurface(const Vec3& p_w) const {
  double best = distanceToBoxSurface(impl_->room.box, p_w);
  for (const auto& f : impl_->furniture) best = std::min(best, distanceToBoxSurface(f.box, p_w));
  return best;
}

bool SyntheticScene::onMovingObject(const Vec3& p_w, double time_s, double tolerance) const {
  if (!impl_->scene.moving_object) return false;
  const Box box = impl_->moverBox(time_s);
  return box.contains(p_w) || box.squaredExteriorDistance(p_w) <= tolerance * tolerance;
}

RenderedFrame SyntheticScene::render(const SE3& T_w_c, double time_s) const {
  const Impl& s = *impl_;
  const Vec3 origin = T_w_c.translation();
  if (!s.room.box.contains(origin))
    throw InputError("SyntheticScene::render: camera centre (" + std::to_string(origin.x()) + ", " +
                     std::to_string(origin.y()) + ", " + std::to_string(origin.z()) +
                     ") is outside the room; use a path inside SceneOptions::room_size");
  const Mat3 R_w_c = T_w_c.rotation();
  const bool has_mover = s.scene.moving_object;
  const Box mover_box = has_mover ? s.moverBox(time_s) : Box();
  const double ppm = s.scene.texture_px_per_m;
  const double sigma = s.scene.depth_noise_sigma;
  const std::uint64_t noise_key = splitmix64(s.scene.seed ^ std::bit_cast<std::uint64_t>(time_s));

  // Per-frame culling: each box's extent in normalised image coordinates (x/z, y/z), so a pixel
  // only tests the boxes whose extent holds its ray. Works with distortion (rays are undistorted).
  struct Candidate {
    const TexturedBox* textured;
    Box box;
    bool dynamic;
    double x0, x1, y0, y1;
  };
  std::vector<Candidate> candidates;
  const SE3 T_c_w = T_w_c.inverse();
  auto addCandidate = [&](const TexturedBox& textured, const Box& box, bool dynamic) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    Candidate c{&textured, box, dynamic, kInf, -kInf, kInf, -kInf};
    int behind = 0;
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 p_c = T_c_w * box.corner(static_cast<Box::CornerType>(corner));
      if (p_c.z() <= 1e-6) { ++behind; continue; }
      c.x0 = std::min(c.x0, p_c.x() / p_c.z()); c.x1 = std::max(c.x1, p_c.x() / p_c.z());
      c.y0 = std::min(c.y0, p_c.y() / p_c.z()); c.y1 = std::max(c.y1, p_c.y() / p_c.z());
    }
    if (behind == 8) return;                        // entirely behind the camera
    if (behind > 0) c = {&textured, box, dynamic, -kInf, kInf, -kInf, kInf};  // straddles: test always
    candidates.push_back(c);
  };
  for (const auto& f : s.furniture) addCandidate(f, f.box, false);
  if (has_mover) addCandidate(s.mover, mover_box, true);

  const int width = s.camera.width, height = s.camera.height;
  RenderedFrame frame{cv::Mat(height, width, CV_8UC3), cv::Mat(height, width, CV_32F),
                      cv::Mat::zeros(height, width, CV_8U)};

  auto renderRows = [&](const cv::Range& rows) {
    SlabHit hit;
    for (int v = rows.start; v < rows.end; ++v) {
      auto* bgr = frame.bgr.ptr<cv::Vec3b>(v);
      auto* depth = frame.depth.ptr<float>(v);
      auto* mask = frame.dynamic_mask.ptr<uchar>(v);
      for (int u = 0; u < width; ++u) {
        const std::size_t index = static_cast<std::size_t>(v) * width + u;
        const cv::Vec2d& ray = s.rays[index];
        const Vec3 d = R_w_c * Vec3(ray[0], ray[1], 1.0);  // unit z in the camera: t is depth
        const Vec3 inv_d = d.cwiseInverse();

        // Nearest surface: the room's exit point, unless a box is entered before it.
        intersect(origin, inv_d, s.room.box, hit);
        double t = hit.t_far;
        int axis = hit.axis_far;
        int side = d[axis] > 0 ? 1 : 0;
        const TexturedBox* surface = &s.room;
        Vec3 surface_min = s.room.box.min();
        bool dynamic = false;
        for (const Candidate& c : candidates) {
          if (ray[0] < c.x0 || ray[0] > c.x1 || ray[1] < c.y0 || ray[1] > c.y1) continue;
          if (intersect(origin, inv_d, c.box, hit) && hit.t_near > 0 && hit.t_near < t) {
            t = hit.t_near;
            axis = hit.axis_near;
            side = d[axis] > 0 ? 0 : 1;
            surface = c.textured;
            surface_min = c.box.min();
            dynamic = c.dynamic;
          }
        }

        const Vec3 p = origin + t * d;
        const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
        bgr[u] = sampleBilinear(surface->textures[2 * axis + side], (p[a1] - surface_min[a1]) * ppm,
                                (p[a2] - surface_min[a2]) * ppm);
        double z = t;
        if (sigma > 0) z = std::max(1e-3, z + sigma * z * z * gaussian(noise_key + index));
        depth[u] = static_cast<float>(z);
        mask[u] = dynamic ? 255 : 0;
      }
    }
  };
#if defined(__SANITIZE_THREAD__)
  // Debian's TBB (OpenCV's parallel backend) is not built for ThreadSanitizer, which then cannot
  // see the loop's join and reports false races: render serially in TSan builds.
  renderRows(cv::Range(0, height));
#else
  cv::parallel_for_(cv::Range(0, height), renderRows);
#endif
  return frame;
}

CameraOptions syntheticCamera() {
  CameraOptions camera;
  camera.fx = camera.fy = 525.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  camera.width = 640;
  camera.height = 480;
  camera.depth_factor = 5000.0;
  camera.fps = 30.0;
  return camera;
}

CameraOptions halfResolution(CameraOptions camera) {
  camera.width /= 2;
  camera.height /= 2;
  camera.fx /= 2;
  camera.fy /= 2;
  camera.cx = (camera.cx + 0.5) / 2 - 0.5;
  camera.cy = (camera.cy + 0.5) / 2 - 0.5;
  return camera;
}

}  // namespace desslam::sim
