#include "feature/keypoint_distribution.hpp"

#include <algorithm>
#include <cmath>

namespace desslam::feature {
namespace {

// A quadtree cell owns the index range [begin, end) of a shared index array, so splitting is an
// in-place partition without allocations.
struct Cell {
  float x0, y0, x1, y1;
  int begin, end;
  int depth;
  int sequence;  // creation order: makes the split order, hence the result, deterministic
  int count() const { return end - begin; }
};

// Split order: shallowest (largest) cells first, so the subdivision stays spatially uniform;
// among equally large cells the most crowded first.
struct SplitsLater {
  bool operator()(const Cell& a, const Cell& b) const {
    if (a.depth != b.depth) return a.depth > b.depth;
    if (a.count() != b.count()) return a.count() < b.count();
    return a.sequence > b.sequence;
  }
};

}  // namespace

std::vector<int> distributeKeypoints(const std::vector<cv::KeyPoint>& candidates, const cv::Rect2f& region,
                                     int wanted) {
  std::vector<int> result;
  if (wanted <= 0 || region.width <= 0 || region.height <= 0) return result;

  std::vector<int> index;
  index.reserve(candidates.size());
  const float rx1 = region.x + region.width, ry1 = region.y + region.height;
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) {
    const cv::Point2f& p = candidates[i].pt;
    if (p.x >= region.x && p.x < rx1 && p.y >= region.y && p.y < ry1) index.push_back(i);
  }
  if (index.empty()) return result;

  const auto pt = [&](int i) -> const cv::Point2f& { return candidates[i].pt; };
  int sequence = 0;
  std::vector<Cell> splittable;  // a heap ordered by SplitsLater
  std::vector<Cell> final_cells;
  int cells = 0;  // non-empty cells in total
  const auto add = [&](const Cell& c) {
    if (c.count() == 0) return;
    ++cells;
    // Cells below a pixel only hold (nearly) coincident corners: splitting them gains nothing.
    if (c.count() == 1 || c.x1 - c.x0 < 1.f || c.y1 - c.y0 < 1.f) {
      final_cells.push_back(c);
    } else {
      splittable.push_back(c);
      std::push_heap(splittable.begin(), splittable.end(), SplitsLater{});
    }
  };

  // Square-ish root cells, so that a wide image is not split into tall thin quadrants.
  const int roots_x = std::max(1, static_cast<int>(std::lround(region.width / region.height)));
  const int roots_y = std::max(1, static_cast<int>(std::lround(region.height / region.width)));
  const float root_w = region.width / roots_x, root_h = region.height / roots_y;
  auto rest = index.begin();
  for (int ry = 0; ry < roots_y; ++ry) {
    for (int rx = 0; rx < roots_x; ++rx) {
      const float x0 = region.x + rx * root_w, y0 = region.y + ry * root_h;
      const float x1 = rx + 1 == roots_x ? rx1 : x0 + root_w, y1 = ry + 1 == roots_y ? ry1 : y0 + root_h;
      auto end = std::partition(rest, index.end(), [&](int i) {
        return pt(i).x >= x0 && pt(i).x < x1 && pt(i).y >= y0 && pt(i).y < y1;
      });
      add(Cell{x0, y0, x1, y1, static_cast<int>(rest - index.begin()), static_cast<int>(end - index.begin()), 0,
               sequence++});
      rest = end;
    }
  }

  while (cells < wanted && !splittable.empty()) {
    std::pop_heap(splittable.begin(), splittable.end(), SplitsLater{});
    const Cell c = splittable.back();
    splittable.pop_back();
    --cells;
    const float xm = 0.5f * (c.x0 + c.x1), ym = 0.5f * (c.y0 + c.y1);
    const auto first = index.begin() + c.begin, last = index.begin() + c.end;
    const auto mid_y = std::partition(first, last, [&](int i) { return pt(i).y < ym; });
    const auto mid_top = std::partition(first, mid_y, [&](int i) { return pt(i).x < xm; });
    const auto mid_bottom = std::partition(mid_y, last, [&](int i) { return pt(i).x < xm; });
    const auto at = [&](auto it) { return static_cast<int>(it - index.begin()); };
    const int d = c.depth + 1;
    add(Cell{c.x0, c.y0, xm, ym, c.begin, at(mid_top), d, sequence++});
    add(Cell{xm, c.y0, c.x1, ym, at(mid_top), at(mid_y), d, sequence++});
    add(Cell{c.x0, ym, xm, c.y1, at(mid_y), at(mid_bottom), d, sequence++});
    add(Cell{xm, ym, c.x1, c.y1, at(mid_bottom), c.end, d, sequence++});
  }

  const auto strongest = [&](const Cell& c) {
    int best = index[c.begin];
    for (int k = c.begin + 1; k < c.end; ++k) {
      const int i = index[k];
      if (candidates[i].response > candidates[best].response ||
          (candidates[i].response == candidates[best].response && i < best))
        best = i;
    }
    return best;
  };
  final_cells.insert(final_cells.end(), splittable.begin(), splittable.end());
  std::sort(final_cells.begin(), final_cells.end(),
            [](const Cell& a, const Cell& b) { return a.sequence < b.sequence; });
  result.reserve(final_cells.size());
  for (const Cell& c : final_cells) result.push_back(strongest(c));

  // The last split may overshoot by up to three cells: drop the weakest picks.
  if (static_cast<int>(result.size()) > wanted) {
    std::stable_sort(result.begin(), result.end(), [&](int a, int b) {
      return candidates[a].response > candidates[b].response;
    });
    result.resize(wanted);
  }
  return result;
}

}  // namespace desslam::feature
