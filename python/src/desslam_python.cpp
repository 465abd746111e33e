// The `desslam` Python module (the extension desslam._desslam, re-exported by desslam/__init__.py):
// the public C++ API (include/desslam/*.hpp) on numpy arrays. Only public headers are used here.
//
// Images: colour HxWx3 uint8 (BGR, OpenCV's order, unless rgb=True), depth HxW float32 metres or
// uint16 raw sensor units (divided by camera.depth_factor). Poses: 4x4 float64 world-from-camera.
// Trajectories: desslam.Trajectory (timestamps (N,), poses (N,4,4), map ids (N,)).
//
// The GIL is released while C++ works (tracking, finishing, loading images, exporting); nothing
// in those sections touches a Python object: inputs are wrapped in cv::Mat headers over numpy
// buffers that the caller's Python objects keep alive, results are turned into Python objects
// after the GIL is taken again.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "desslam/dataset.hpp"
#include "desslam/desslam.hpp"
#include "desslam/evaluation.hpp"

namespace py = pybind11;

namespace desslam::python {
namespace {

py::object jsonLoads(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

std::string shapeText(const py::array& a) {
  std::string out = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) out += (i ? ", " : "") + std::to_string(a.shape(i));
  return out + (a.ndim() == 1 ? ",)" : ")");
}

std::string dtypeText(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

// ---- images: numpy -> cv::Mat headers over the same memory (C-contiguous copies where needed) ----

// `keep` holds the (possibly contiguous copy of the) array the returned header points into.
cv::Mat colourHeader(const py::array& image, py::array& keep) {
  if (!image.dtype().is(py::dtype::of<std::uint8_t>()))
    throw py::type_error("bgr: the colour image must be a uint8 array (HxWx3), got dtype " + dtypeText(image));
  if (image.ndim() != 3 || image.shape(2) != 3)
    throw py::value_error("bgr: the colour image must have shape (H, W, 3), got " + shapeText(image));
  keep = py::array_t<std::uint8_t, py::array::c_style>::ensure(image);
  return cv::Mat(static_cast<int>(keep.shape(0)), static_cast<int>(keep.shape(1)), CV_8UC3,
                 const_cast<void*>(keep.data()));
}

cv::Mat depthHeader(const py::array& depth, py::array& keep) {
  int type = -1;
  if (depth.dtype().is(py::dtype::of<float>()))
    type = CV_32FC1;
  else if (depth.dtype().is(py::dtype::of<std::uint16_t>()))
    type = CV_16UC1;
  else
    throw py::type_error("depth: the depth image must be float32 (metres) or uint16 (raw units, divided by "
                         "camera.depth_factor), got dtype " + dtypeText(depth) +
                         " (e.g. depth.astype(numpy.float32) for metres)");
  if (depth.ndim() != 2)
    throw py::value_error("depth: the depth image must have shape (H, W), got " + shapeText(depth));
  if (type == CV_32FC1)
    keep = py::array_t<float, py::array::c_style>::ensure(depth);
  else
    keep = py::array_t<std::uint16_t, py::array::c_style>::ensure(depth);
  return cv::Mat(static_cast<int>(keep.shape(0)), static_cast<int>(keep.shape(1)), type,
                 const_cast<void*>(keep.data()));
}

// cv::Mat -> numpy without a copy: the array owns a heap cv::Mat (shares its buffer).
py::array toArray(cv::Mat mat) {
  if (!mat.isContinuous()) mat = mat.clone();
  auto* owner = new cv::Mat(std::move(mat));
  py::capsule base(owner, [](void* p) { delete static_cast<cv::Mat*>(p); });
  const std::vector<py::ssize_t> shape =
      owner->channels() == 1 ? std::vector<py::ssize_t>{owner->rows, owner->cols}
                             : std::vector<py::ssize_t>{owner->rows, owner->cols, owner->channels()};
  switch (owner->depth()) {
    case CV_8U:
      return py::array_t<std::uint8_t>(shape, owner->ptr<std::uint8_t>(), base);
    case CV_16U:
      return py::array_t<std::uint16_t>(shape, owner->ptr<std::uint16_t>(), base);
    case CV_32F:
      return py::array_t<float>(shape, owner->ptr<float>(), base);
    default:
      throw std::runtime_error("internal: unexpected image type " + std::to_string(owner->type()));
  }
}

// ---- trajectories ----

// desslam.Trajectory: timestamps (N,) float64 seconds, poses (N,4,4) float64 T_w_c, map_ids and
// world_map_ids (N,) int32 (the map a frame was tracked in, the map whose world its pose is in).
// C-contiguous arrays of one dtype; numbers of another dtype are converted on the way in.
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IdArray = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>;

struct Trajectory {
  DoubleArray timestamps;
  DoubleArray poses;
  IdArray map_ids;
  IdArray world_map_ids;

  std::size_t size() const { return static_cast<std::size_t>(timestamps.shape(0)); }
};

Trajectory makeTrajectory(const py::object& timestamps_in, const py::object& poses_in, const py::object& map_ids_in,
                          const py::object& world_map_ids_in) {
  // Numbers of any dtype are accepted and converted (forcecast); shapes are checked.
  const DoubleArray timestamps = DoubleArray::ensure(timestamps_in);
  const DoubleArray poses = DoubleArray::ensure(poses_in);
  if (!timestamps || timestamps.ndim() != 1)
    throw py::value_error("Trajectory: timestamps must be a 1-D array of seconds (N,)");
  const py::ssize_t n = timestamps.shape(0);
  if (!poses || poses.ndim() != 3 || poses.shape(0) != n || poses.shape(1) != 4 || poses.shape(2) != 4)
    throw py::value_error("Trajectory: poses must have shape (N, 4, 4) with N = " + std::to_string(n) +
                          " (the number of timestamps), got " + (poses ? shapeText(poses) : std::string("no array")));
  const auto ids = [n](const py::object& in, const char* name) {
    if (in.is_none()) {
      IdArray zeros(n);
      std::fill(zeros.mutable_data(), zeros.mutable_data() + n, 0);
      return zeros;
    }
    IdArray a = IdArray::ensure(in);
    if (!a || a.ndim() != 1 || a.shape(0) != n)
      throw py::value_error(std::string("Trajectory: ") + name + " must have shape (" + std::to_string(n) + ",)");
    return a;
  };
  const IdArray map_ids = ids(map_ids_in, "map_ids");
  // World map ids default to the map ids (a trajectory without merges).
  const IdArray world_map_ids = world_map_ids_in.is_none() ? map_ids : ids(world_map_ids_in, "world_map_ids");
  return {timestamps, poses, map_ids, world_map_ids};
}

Trajectory toPython(const std::vector<FramePose>& poses) {
  const auto n = static_cast<py::ssize_t>(poses.size());
  DoubleArray timestamps(n);
  DoubleArray matrices({n, py::ssize_t{4}, py::ssize_t{4}});
  IdArray map_ids(n), world_map_ids(n);
  double* t = timestamps.mutable_data();
  double* m = matrices.mutable_data();
  std::int32_t* ids = map_ids.mutable_data();
  std::int32_t* world_ids = world_map_ids.mutable_data();
  for (py::ssize_t i = 0; i < n; ++i) {
    const FramePose& p = poses[static_cast<std::size_t>(i)];
    t[i] = p.timestamp_s;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m[i * 16 + r * 4 + c] = p.T_w_c(r, c);
    ids[i] = p.map_id;
    world_ids[i] = p.world_map_id;
  }
  return {timestamps, matrices, map_ids, world_map_ids};
}

std::vector<FramePose> toCpp(const Trajectory& trajectory) {
  std::vector<FramePose> out(trajectory.size());
  const double* t = trajectory.timestamps.data();
  const double* m = trajectory.poses.data();
  const std::int32_t* ids = trajectory.map_ids.data();
  const std::int32_t* world_ids = trajectory.world_map_ids.data();
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i].timestamp_s = t[i];
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) out[i].T_w_c(r, c) = m[i * 16 + r * 4 + c];
    out[i].map_id = ids[i];
    out[i].world_map_id = world_ids[i];
  }
  return out;
}

bool isPath(const py::object& o) {
  return py::isinstance<py::str>(o) || py::isinstance(o, py::module_::import("os").attr("PathLike"));
}

// A trajectory argument: a desslam.Trajectory, a TUM file's path, or (timestamps, poses).
std::vector<FramePose> trajectoryArgument(const py::object& o, const char* name) {
  if (py::isinstance<Trajectory>(o)) return toCpp(o.cast<const Trajectory&>());
  if (isPath(o)) return readTumTrajectory(o.cast<std::filesystem::path>());
  if (py::isinstance<py::tuple>(o) && py::len(o) == 2) {
    const py::tuple pair = o.cast<py::tuple>();
    return toCpp(makeTrajectory(pair[0], pair[1], py::none(), py::none()));
  }
  throw py::type_error(std::string(name) +
                       ": expected a desslam.Trajectory, a TUM trajectory file's path or a (timestamps, poses) tuple");
}

// ---- the system ----

// One Slam per Python object, guarded by a mutex: rclpy's multi-threaded executors may call back
// from several threads, and the C++ object is used from one thread at a time. The mutex is taken
// after the GIL is released (never the other way round), so the two cannot deadlock.
struct PySlam {
  std::unique_ptr<Slam> slam;
  std::mutex mutex;
};

std::unique_ptr<PySlam> makeSlam(const Config& config, bool deterministic, bool realtime) {
  py::gil_scoped_release release;
  auto out = std::make_unique<PySlam>();
  out->slam = std::make_unique<Slam>(config, RunMode{deterministic, realtime});
  return out;
}

TrackResult track(PySlam& self, double timestamp_s, const py::array& bgr, const py::array& depth,
                  double depth_time_offset_s, const std::string& image_name, bool rgb) {
  py::array bgr_keep, depth_keep;  // keep the buffers alive (and their reference counts untouched) below
  const cv::Mat bgr_mat = colourHeader(bgr, bgr_keep);
  const cv::Mat depth_mat = depthHeader(depth, depth_keep);
  py::gil_scoped_release release;
  std::lock_guard lock(self.mutex);
  if (!rgb) return self.slam->track(timestamp_s, bgr_mat, depth_mat, depth_time_offset_s, image_name);
  cv::Mat swapped;
  cv::cvtColor(bgr_mat, swapped, cv::COLOR_RGB2BGR);
  return self.slam->track(timestamp_s, swapped, depth_mat, depth_time_offset_s, image_name);
}

// Runs `f` on the Slam with the GIL released and the object's mutex held.
template <typename F>
auto withSlam(PySlam& self, F&& f) {
  py::gil_scoped_release release;
  std::lock_guard lock(self.mutex);
  return f(*self.slam);
}

const char* stateName(TrackingState s) {
  switch (s) {
    case TrackingState::kNotInitialised: return "NOT_INITIALISED";
    case TrackingState::kTracking: return "TRACKING";
    case TrackingState::kPredicted: return "PREDICTED";
    case TrackingState::kLost: return "LOST";
  }
  return "?";
}

std::string summaryRepr(const ErrorSummary& s) {
  return "ErrorSummary(rmse=" + std::to_string(s.rmse) + ", mean=" + std::to_string(s.mean) +
         ", median=" + std::to_string(s.median) + ", max=" + std::to_string(s.max) +
         ", count=" + std::to_string(s.count) + ")";
}

}  // namespace

void bind(py::module_& m) {
  m.doc() = "DeS-SLAM: RGB-D SLAM for dynamic scenes, on numpy arrays (see the README's Python section)";
  m.def("version", &version, "The library's version, e.g. '0.1.0'");

  // ---- Config ----
  py::class_<Config>(m, "Config",
                     "A run's options: every stage's settings from a YAML file (config/*.yaml) and "
                     "'section.key=value' assignments")
      .def_static("from_yaml", &Config::fromYaml, py::arg("path"), "Reads and validates a YAML config file")
      .def_static("from_yaml_string", &Config::fromYamlString, py::arg("yaml"), py::arg("name") = "<config>",
                  "The same for YAML text; `name` stands for it in messages")
      .def("set", py::overload_cast<const std::string&>(&Config::set), py::arg("assignment"),
           py::return_value_policy::reference_internal,
           "One 'section.key=value' assignment (value read as YAML); returns the config")
      .def("set", py::overload_cast<const std::string&, const std::string&>(&Config::set), py::arg("key"),
           py::arg("value"), py::return_value_policy::reference_internal)
      .def("validate", &Config::validate, "Raises naming the first option out of range")
      .def("to_json", &Config::toJson, "Every section and key with its value, as JSON text")
      .def("to_dict", [](const Config& c) { return jsonLoads(c.toJson()); }, "Every section and key, as a dict")
      .def("__copy__", [](const Config& c) { return Config(c); })
      .def("__deepcopy__", [](const Config& c, const py::object&) { return Config(c); });

  // ---- results ----
  py::enum_<TrackingState>(m, "TrackingState")
      .value("NOT_INITIALISED", TrackingState::kNotInitialised, "no map has started yet")
      .value("TRACKING", TrackingState::kTracking, "tracked against the map")
      .value("PREDICTED", TrackingState::kPredicted, "lost briefly: the motion prediction is its pose")
      .value("LOST", TrackingState::kLost, "no pose");

  py::class_<TrackResult>(m, "TrackResult", "What Slam.track found for one frame")
      .def_readonly("state", &TrackResult::state)
      .def_property_readonly(
          "T_w_c", [](const TrackResult& r) { return Eigen::Matrix4d(r.T_w_c); },
          "4x4 float64 world-from-camera in the world of map `map_id` (identity without a pose)")
      .def_readonly("map_id", &TrackResult::map_id, "the atlas map T_w_c is in (-1: no pose)")
      .def_property_readonly(
          "T_odom_c", [](const TrackResult& r) { return Eigen::Matrix4d(r.T_odom_c); },
          "4x4 float64 pose in the odometry frame: continuous where T_w_c jumps (a new map, a merge, a loop "
          "correction); it drifts and is never corrected (identity without a pose)")
      .def_readonly("keyframe", &TrackResult::keyframe)
      .def_readonly("new_map", &TrackResult::new_map)
      .def_readonly("inliers", &TrackResult::inliers)
      .def_property_readonly("has_pose", &TrackResult::hasPose)
      .def("__repr__", [](const TrackResult& r) {
        return std::string("TrackResult(state=") + stateName(r.state) + ", map_id=" + std::to_string(r.map_id) +
               ", keyframe=" + (r.keyframe ? "True" : "False") + ", inliers=" + std::to_string(r.inliers) + ")";
      });

  py::class_<Trajectory>(m, "Trajectory",
                         "Timestamped poses: timestamps (N,) seconds, poses (N,4,4) float64 world-from-camera, "
                         "map_ids / world_map_ids (N,) int32")
      .def(py::init(&makeTrajectory), py::arg("timestamps"), py::arg("poses"), py::arg("map_ids") = py::none(),
           py::arg("world_map_ids") = py::none())
      .def_readonly("timestamps", &Trajectory::timestamps)
      .def_readonly("poses", &Trajectory::poses)
      .def_readonly("map_ids", &Trajectory::map_ids)
      .def_readonly("world_map_ids", &Trajectory::world_map_ids)
      .def_property_readonly(
          "positions",
          [](const Trajectory& t) { return py::object(t.poses[py::make_tuple(py::ellipsis(), py::slice(0, 3, 1), 3)]); },
          "(N,3) camera positions in the world (a view into poses)")
      .def("__len__", &Trajectory::size)
      .def("__repr__", [](const Trajectory& t) { return "Trajectory(" + std::to_string(t.size()) + " poses)"; });

  // ---- the system ----
  py::class_<PySlam>(m, "Slam",
                     "The SLAM system. track() frames in time order, then finish(). One object is used from one "
                     "thread at a time (calls from several threads are serialised).")
      .def(py::init(&makeSlam), py::arg("config"), py::kw_only(), py::arg("deterministic") = false,
           py::arg("realtime") = false,
           "Starts every stage (loads the vocabulary and the model the config names). deterministic: every "
           "stage waits for the one before it (two runs give identical trajectories); realtime: tracking "
           "never waits for the network")
      .def(py::init([](const std::filesystem::path& yaml, bool deterministic, bool realtime) {
             return makeSlam(Config::fromYaml(yaml), deterministic, realtime);
           }),
           py::arg("config"), py::kw_only(), py::arg("deterministic") = false, py::arg("realtime") = false,
           "The same with a YAML config file's path")
      .def("track", &track, py::arg("timestamp"), py::arg("bgr"), py::arg("depth"), py::arg("depth_time_offset") = 0.0,
           py::arg("image_name") = "", py::kw_only(), py::arg("rgb") = false,
           "Tracks one RGB-D frame. bgr: HxWx3 uint8 in BGR order (rgb=True: RGB order); depth: HxW float32 "
           "metres or uint16 raw units (divided by camera.depth_factor), 0 = no reading; both of the config's "
           "camera size. depth_time_offset: how much later (s) the depth image was taken. Returns a TrackResult.")
      .def("finish", [](PySlam& self) { withSlam(self, [](Slam& s) { s.finish(); }); },
           "Waits for mapping, runs the final global bundle adjustment, stops the threads (idempotent)")
      .def("trajectory", [](PySlam& self) { return toPython(withSlam(self, [](Slam& s) { return s.trajectory(); })); },
           "The frames of the main map (the one that, after all merges, holds the most frames)")
      .def("trajectory_all",
           [](PySlam& self) { return toPython(withSlam(self, [](Slam& s) { return s.trajectoryAll(); })); },
           "Every frame with a pose in any map")
      .def("keyframe_trajectory",
           [](PySlam& self) { return toPython(withSlam(self, [](Slam& s) { return s.keyframeTrajectory(); })); },
           "Every keyframe of the atlas (map_ids: its map)")
      .def("odometry_trajectory",
           [](PySlam& self) { return toPython(withSlam(self, [](Slam& s) { return s.odometryTrajectory(); })); },
           "Every frame that had a pose, as TrackResult.T_odom_c gave it (world_map_ids: -1, the odometry frame; "
           "not for an ATE: motions across a loss that started a map are extrapolated)")
      .def(
          "export_dense_map",
          [](PySlam& self, const std::filesystem::path& directory, bool semantic_colour) {
            return jsonLoads(withSlam(self, [&](Slam& s) { return s.exportDenseMap(directory, semantic_colour); }));
          },
          py::arg("directory"), py::arg("semantic_colour") = false,
          "After finish(): writes dense_map.ply/.pcd/.png and octomap.bt into directory; returns what was written")
      .def("statistics", [](PySlam& self) { return jsonLoads(withSlam(self, [](Slam& s) { return s.statisticsJson(); })); },
           "Counts, timings and per-frame statistics (report.json's 'statistics') as a dict")
      .def_property_readonly("frames_processed",
                             [](PySlam& self) { return withSlam(self, [](Slam& s) { return s.framesProcessed(); }); })
      .def_property_readonly("config", [](PySlam& self) { return Config(self.slam->config()); },
                             "A copy of the config the system runs with")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](PySlam& self, const py::object&, const py::object&, const py::object&) {
        withSlam(self, [](Slam& s) { s.finish(); });
        return false;
      });

  // ---- evaluation ----
  py::class_<ErrorSummary>(m, "ErrorSummary", "Summary of a list of errors (std: population standard deviation)")
      .def_readonly("rmse", &ErrorSummary::rmse)
      .def_readonly("mean", &ErrorSummary::mean)
      .def_readonly("median", &ErrorSummary::median)
      .def_readonly("std", &ErrorSummary::std)
      .def_readonly("min", &ErrorSummary::min)
      .def_readonly("max", &ErrorSummary::max)
      .def_readonly("count", &ErrorSummary::count)
      .def("__repr__", &summaryRepr);
  py::class_<AteFigures>(m, "AteFigures", "Absolute trajectory error after one rigid alignment")
      .def_readonly("translation_m", &AteFigures::translation_m)
      .def_property_readonly("T_gt_est", [](const AteFigures& a) { return Eigen::Matrix4d(a.T_gt_est); },
                             "4x4 float64: maps the estimate's world into the ground truth's")
      .def_readonly("matched", &AteFigures::matched)
      .def_readonly("gt_poses", &AteFigures::gt_poses)
      .def_readonly("est_poses", &AteFigures::est_poses)
      .def_readonly("alignment_unique", &AteFigures::alignment_unique);
  py::class_<RpeFigures>(m, "RpeFigures", "Relative pose error over windows of delta_s seconds")
      .def_readonly("translation_m", &RpeFigures::translation_m)
      .def_readonly("rotation_deg", &RpeFigures::rotation_deg)
      .def_readonly("delta_s", &RpeFigures::delta_s)
      .def_readonly("pairs", &RpeFigures::pairs);
  py::class_<Evaluation>(m, "Evaluation", "ATE and RPE, as `desslam eval` computes them")
      .def_readonly("ate", &Evaluation::ate)
      .def_readonly("rpe", &Evaluation::rpe)
      .def_readonly("max_dt", &Evaluation::max_dt)
      .def("to_dict", [](const Evaluation& e) { return jsonLoads(e.toJson()); },
           "{'ate': ..., 'rpe': ...}: the objects `desslam eval --json` prints")
      .def("table", &Evaluation::table, "The table `desslam eval` prints")
      .def("__repr__", &Evaluation::table);

  const char* trajectory_args =
      " groundtruth/estimate: a desslam.Trajectory, a TUM file's path or a (timestamps (N,), poses (N,4,4)) tuple.";
  m.def(
      "evaluate",
      [](const py::object& gt, const py::object& est, double max_dt, double delta_s) {
        if (isPath(gt) && isPath(est))  // exactly `desslam eval <gt> <est>` (messages name the files)
          return evaluateFiles(gt.cast<std::filesystem::path>(), est.cast<std::filesystem::path>(), max_dt, delta_s);
        return evaluate(trajectoryArgument(gt, "groundtruth"), trajectoryArgument(est, "estimate"), max_dt, delta_s);
      },
      py::arg("groundtruth"), py::arg("estimate"), py::arg("max_dt") = 0.02, py::arg("delta_s") = 1.0,
      (std::string("ATE and RPE, associating poses within max_dt seconds.") + trajectory_args).c_str());
  m.def(
      "ate",
      [](const py::object& gt, const py::object& est, double max_dt) {
        return computeAte(trajectoryArgument(gt, "groundtruth"), trajectoryArgument(est, "estimate"), max_dt);
      },
      py::arg("groundtruth"), py::arg("estimate"), py::arg("max_dt") = 0.02,
      (std::string("Absolute trajectory error.") + trajectory_args).c_str());
  m.def(
      "rpe",
      [](const py::object& gt, const py::object& est, double delta_s, double max_dt) {
        return computeRpe(trajectoryArgument(gt, "groundtruth"), trajectoryArgument(est, "estimate"), delta_s, max_dt);
      },
      py::arg("groundtruth"), py::arg("estimate"), py::arg("delta_s") = 1.0, py::arg("max_dt") = 0.02,
      (std::string("Relative pose error over delta_s seconds.") + trajectory_args).c_str());

  // ---- files ----
  m.def(
      "read_tum_trajectory", [](const std::filesystem::path& path) { return toPython(readTumTrajectory(path)); },
      py::arg("path"), "Reads a TUM trajectory file (timestamp tx ty tz qx qy qz qw) into a Trajectory");
  m.def(
      "write_tum_trajectory",
      [](const std::filesystem::path& path, const py::object& trajectory) {
        writeTumTrajectory(path, trajectoryArgument(trajectory, "trajectory"));
      },
      py::arg("path"), py::arg("trajectory"), "Writes a Trajectory as a TUM file (atomically)");

  py::class_<RgbdFrame>(m, "RgbdFrame", "A loaded RGB-D pair")
      .def_readonly("timestamp", &RgbdFrame::timestamp_s, "the RGB image's time (s)")
      .def_readonly("depth_time_offset", &RgbdFrame::depth_time_offset_s, "how much later the depth was taken (s)")
      .def_property_readonly("bgr", [](const RgbdFrame& f) { return toArray(f.bgr); }, "HxWx3 uint8, BGR order")
      .def_property_readonly("depth", [](const RgbdFrame& f) { return toArray(f.depth_m); }, "HxW float32 metres")
      .def_readonly("image_name", &RgbdFrame::image_name, "the RGB file's name");

  py::class_<TumDataset>(m, "TumDataset",
                         "A sequence folder in the TUM layout (rgb/, depth/, rgb.txt, depth.txt[, groundtruth.txt]); "
                         "RGB and depth paired by nearest timestamp within max_dt")
      .def(py::init([](const std::filesystem::path& directory, double max_dt) {
             py::gil_scoped_release release;
             return TumDataset::open(directory, max_dt);
           }),
           py::arg("directory"), py::arg("max_dt") = 0.02)
      .def("__len__", &TumDataset::size)
      .def(
          "load",
          [](const TumDataset& d, std::size_t i, const Config& config) {
            py::gil_scoped_release release;
            return d.load(i, config);
          },
          py::arg("index"), py::arg("config"),
          "Loads frame `index` (images of the config's camera size, depth / camera.depth_factor)")
      .def_property_readonly("timestamps",
                             [](const TumDataset& d) {
                               py::array_t<double> t(static_cast<py::ssize_t>(d.size()));
                               for (std::size_t i = 0; i < d.size(); ++i) t.mutable_at(i) = d.frames()[i].timestamp_s;
                               return t;
                             })
      .def_property_readonly("depth_timestamps",
                             [](const TumDataset& d) {
                               py::array_t<double> t(static_cast<py::ssize_t>(d.size()));
                               for (std::size_t i = 0; i < d.size(); ++i)
                                 t.mutable_at(i) = d.frames()[i].depth_timestamp_s;
                               return t;
                             })
      .def_property_readonly("rgb_paths",
                             [](const TumDataset& d) {
                               std::vector<std::string> out;
                               for (const RgbdFrameInfo& f : d.frames()) out.push_back(f.rgb_path.string());
                               return out;
                             })
      .def_property_readonly("depth_paths",
                             [](const TumDataset& d) {
                               std::vector<std::string> out;
                               for (const RgbdFrameInfo& f : d.frames()) out.push_back(f.depth_path.string());
                               return out;
                             })
      .def_property_readonly(
          "ground_truth",
          [](const TumDataset& d) -> py::object {
            const std::optional<std::vector<FramePose>> gt = d.groundTruth();
            if (!gt) return py::none();
            return py::cast(toPython(*gt));
          },
          "groundtruth.txt as a Trajectory, or None")
      .def_property_readonly("ground_truth_problem", &TumDataset::groundTruthProblem)
      .def_property_readonly("warnings", &TumDataset::warnings)
      .def_property_readonly("directory", &TumDataset::directory);
}

}  // namespace desslam::python

PYBIND11_MODULE(_desslam, m) { desslam::python::bind(m); }
