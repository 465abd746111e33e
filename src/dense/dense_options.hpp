// dense.*: the dense map (dense/dense_map.hpp) and its thread.
#pragma once

#include "core/option_fields.hpp"

namespace desslam {

struct DenseOptions {
  bool enabled = true;
  double voxel_size = 0.01;      // metres
  double min_depth = 0.1;        // metres
  double max_depth = 4.0;        // metres
  int pixel_stride = 2;          // back-project every n-th pixel in u and v
  int outlier_neighbors = 20;    // statistical outlier removal
  double outlier_std_ratio = 2.0;
  double octomap_resolution = 0.05;  // metres
  // Bound on the OctoMap's size: the cells (leaves) its tree may get, estimated from the keyframe
  // clouds before the export (map_export.hpp octomapCost). A finer octomap_resolution that would
  // give more is coarsened (doubled until it fits) with a warning: time and memory grow as about
  // 1/resolution^3 (fr1_xyz, 10 keyframes: 2.6e5 cells at 0.05 m, 5.6e7 at 0.005 m: 60 s,
  // 1.8 GiB; 0.001 m on 1 keyframe: 200 s and 9 GiB, sparse rays taking ~130 bytes a cell).
  // 2e7 (77 times what the default resolution gives there): up to ~1 min and ~3 GiB on the
  // project's machine.
  double octomap_max_cells = 2e7;
  // The exclude (dynamic) mask is grown by this radius before back-projection: depth at a
  // person's silhouette bleeds into the background, and those pixels would leave ghosts.
  int exclude_dilation_px = 3;
  // Pixels whose depth differs from a 4-neighbour by more than this share of their depth are
  // dropped ("flying pixels" at depth discontinuities); 0 keeps them.
  double depth_edge_ratio = 0.05;
  int queue_capacity = 16;           // keyframes waiting for the dense mapping thread
  int render_width = 1024;           // PNG preview of the map (pixels)
  int render_height = 768;
  // Exported voxels must have been seen by at least this many keyframes (1 = all voxels).
  int min_observations = 1;
  // Free-space carving: each new keyframe's depth is compared with the voxels already in the map;
  // a voxel it sees THROUGH (every reading in a 3x3 window more than carve_tolerance beyond it)
  // gets a miss, and voxels with at least as many misses as observations are left out of the export. The
  // ghost of a person who walked on is seen through by the keyframes that follow; a static
  // surface is not (depth checks and masks miss parts of people: dark clothes, limbs).
  // Part of the dynamic-scene handling: `dynamic.mode: off` (the plain core) turns it off too.
  bool carve_free_space = true;
  double carve_tolerance = 0.05;  // metres

  static constexpr const char* kSection = "dense";
  template <class V> void fields(V& v) {
    v("enabled", enabled); v("voxel_size", voxel_size); v("min_depth", min_depth);
    v("max_depth", max_depth); v("pixel_stride", pixel_stride);
    v("outlier_neighbors", outlier_neighbors); v("outlier_std_ratio", outlier_std_ratio);
    v("octomap_resolution", octomap_resolution); v("octomap_max_cells", octomap_max_cells);
    v("exclude_dilation_px", exclude_dilation_px);
    v("depth_edge_ratio", depth_edge_ratio); v("queue_capacity", queue_capacity);
    v("render_width", render_width); v("render_height", render_height);
    v("min_observations", min_observations); v("carve_free_space", carve_free_space);
    v("carve_tolerance", carve_tolerance);
  }
  void validate() const;
};

}  // namespace desslam
