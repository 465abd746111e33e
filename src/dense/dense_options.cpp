#include "dense/dense_options.hpp"

namespace desslam {

void DenseOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "voxel_size", voxel_size, 0.001, 1.0);
  requireInRange(s, "min_depth", min_depth, 0.0, 100.0);
  requireInRange(s, "max_depth", max_depth, min_depth, 100.0);
  requireInRange(s, "pixel_stride", pixel_stride, 1, 64);
  requireInRange(s, "outlier_neighbors", outlier_neighbors, 0, 1000);
  requireInRange(s, "outlier_std_ratio", outlier_std_ratio, 0.01, 100.0);
  requireInRange(s, "octomap_resolution", octomap_resolution, 0.001, 10.0);
  requireInRange(s, "octomap_max_cells", octomap_max_cells, 1e3, 1e13);
  requireInRange(s, "exclude_dilation_px", exclude_dilation_px, 0, 100);
  requireInRange(s, "depth_edge_ratio", depth_edge_ratio, 0.0, 10.0);
  requireInRange(s, "queue_capacity", queue_capacity, 1, 100000);
  requireInRange(s, "render_width", render_width, 16, 16384);
  requireInRange(s, "render_height", render_height, 16, 16384);
  requireInRange(s, "min_observations", min_observations, 1, 1000000);
  requireInRange(s, "carve_tolerance", carve_tolerance, 0.001, 10.0);
}

}  // namespace desslam
