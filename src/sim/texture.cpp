#include "sim/texture.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace desslam::sim {

namespace {

constexpr double kShapesPerSquareMetre = 500.0;
constexpr double kMinShapeSize = 0.012;  // metres: still a few pixels at 3 m
constexpr double kMaxShapeSize = 0.45;   // metres: large blobs give coarse pyramid levels texture

// Dark or bright grey level with a colour tint: strong grey edges between most neighbours.
cv::Scalar randomColour(cv::RNG& rng) {
  const bool bright = rng.uniform(0, 2) == 1;
  const int grey = bright ? rng.uniform(160, 246) : rng.uniform(10, 96);
  auto channel = [&] { return std::clamp(grey + rng.uniform(-45, 46), 0, 255); };
  return cv::Scalar(channel(), channel(), channel());
}

std::vector<cv::Point> regularPolygon(cv::Point2d centre, double radius, int corners, double angle,
                                      double jitter, cv::RNG& rng) {
  std::vector<cv::Point> points;
  for (int i = 0; i < corners; ++i) {
    const double a = angle + 2.0 * CV_PI * i / corners + rng.uniform(-jitter, jitter);
    const double r = radius * (1.0 - rng.uniform(0.0, jitter));
    points.emplace_back(cv::Point(cvRound(centre.x + r * std::cos(a)), cvRound(centre.y + r * std::sin(a))));
  }
  return points;
}

void drawShape(cv::Mat& image, double size_px, cv::RNG& rng) {
  const cv::Point2d centre(rng.uniform(-0.05, 1.05) * image.cols, rng.uniform(-0.05, 1.05) * image.rows);
  const cv::Scalar colour = randomColour(rng);
  const double angle = rng.uniform(0.0, CV_PI);
  const double r = 0.5 * size_px;
  switch (rng.uniform(0, 5)) {
    case 0: {  // rectangle of random aspect
      const double aspect = rng.uniform(0.3, 1.0);
      const cv::RotatedRect rect(centre, cv::Size2f(float(size_px), float(size_px * aspect)), float(angle * 180 / CV_PI));
      cv::Point2f corners[4];
      rect.points(corners);
      std::vector<cv::Point> points(corners, corners + 4);
      cv::fillConvexPoly(image, points, colour, cv::LINE_8);
      break;
    }
    case 1:  // ellipse
      cv::ellipse(image, cv::Point(centre), cv::Size(std::max(1, cvRound(r)), std::max(1, cvRound(r * rng.uniform(0.3, 1.0)))),
                  angle * 180 / CV_PI, 0, 360, colour, cv::FILLED, cv::LINE_8);
      break;
    case 2:  // triangle
      cv::fillConvexPoly(image, regularPolygon(centre, r, 3, angle, 0.4, rng), colour, cv::LINE_8);
      break;
    case 3: {  // bar
      const cv::Point2d half(r * std::cos(angle), r * std::sin(angle));
      cv::line(image, cv::Point(centre - half), cv::Point(centre + half), colour,
               std::max(1, cvRound(size_px * rng.uniform(0.06, 0.2))), cv::LINE_8);
      break;
    }
    default: {  // irregular (possibly non-convex) polygon
      const std::vector<std::vector<cv::Point>> polygons{regularPolygon(centre, r, rng.uniform(5, 8), angle, 0.6, rng)};
      cv::fillPoly(image, polygons, colour, cv::LINE_8);
      break;
    }
  }
}

}  // namespace

cv::Mat makeSurfaceTexture(double width_m, double height_m, double px_per_m, std::uint64_t seed) {
  // One texel of margin so bilinear sampling at the far edge stays inside.
  const int cols = std::max(2, static_cast<int>(std::ceil(width_m * px_per_m)) + 2);
  const int rows = std::max(2, static_cast<int>(std::ceil(height_m * px_per_m)) + 2);
  cv::RNG rng(seed);
  cv::Mat image(rows, cols, CV_8UC3, randomColour(rng));

  const int count = static_cast<int>(kShapesPerSquareMetre * width_m * height_m) + 4;
  std::vector<double> sizes(count);
  const double log_min = std::log(kMinShapeSize), log_max = std::log(kMaxShapeSize);
  for (double& s : sizes) s = std::exp(rng.uniform(log_min, log_max)) * px_per_m;
  std::sort(sizes.begin(), sizes.end(), std::greater<>());
  for (double size_px : sizes) drawShape(image, size_px, rng);
  return image;
}

}  // namespace desslam::sim
