// Spatially even selection of keypoints by recursive quadtree subdivision (the ORB-SLAM idea):
// the region is split into quadrants, largest cells first, until there are as many non-empty
// cells as wanted keypoints; each cell then keeps its strongest keypoint. Sparse areas end up
// with one keypoint per (large) cell while dense areas get many small cells, so weakly textured
// parts of the image keep their share instead of losing everything to the strongest corners.
#pragma once

#include <vector>

#include <opencv2/core/types.hpp>

namespace desslam::feature {

// Indices into `candidates` of at most `wanted` keypoints inside `region` (candidates outside it
// are ignored), one per quadtree cell, the strongest by `response` (ties: the lower index).
// Deterministic. The order of the result is by cell, not by response.
std::vector<int> distributeKeypoints(const std::vector<cv::KeyPoint>& candidates, const cv::Rect2f& region,
                                     int wanted);

}  // namespace desslam::feature
