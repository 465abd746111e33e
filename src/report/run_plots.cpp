#include "report/run_plots.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "eval/metrics.hpp"
#include "plot/figure.hpp"
#include "plot/scale.hpp"
#include "plot/svg.hpp"

namespace desslam::report {
namespace {

using nlohmann::json;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Colours (the "tab10" palette: distinct, and readable for the common colour-vision deficiencies
// when paired with the line styles used here).
constexpr const char* kBlue = "#1f77b4";
constexpr const char* kOrange = "#ff7f0e";
constexpr const char* kGreen = "#2ca02c";
constexpr const char* kRed = "#d62728";
constexpr const char* kPurple = "#9467bd";
constexpr const char* kBrown = "#8c564b";
constexpr const char* kGrey = "#555555";
constexpr const char* kPink = "#e377c2";

const std::vector<std::string> kPlotIds = {"trajectory_top", "trajectory_side", "ate_over_time",
                                           "rpe_over_time",  "dynamic_features", "stage_timings"};

double number(const json& j, const char* key, double fallback = kNaN) {
  if (!j.is_object()) return fallback;
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : fallback;
}

bool flag(const json& j, const char* key) {
  if (!j.is_object()) return false;
  const auto it = j.find(key);
  return it != j.end() && it->is_boolean() && it->get<bool>();
}

const json& perFrame(const json& report) {
  static const json empty = json::array();
  if (!report.is_object() || !report.contains("statistics")) return empty;
  const json& stats = report["statistics"];
  if (!stats.is_object() || !stats.contains("per_frame") || !stats["per_frame"].is_array()) return empty;
  return stats["per_frame"];
}

std::string fixed(double v, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, v);
  return text;
}

// Where consecutive samples are further apart than this, a line is broken (frames without a pose,
// withheld frames): 5 frame spacings, at least 0.25 s.
double gapSeconds(const std::vector<double>& times) {
  std::vector<double> dt;
  for (size_t k = 1; k < times.size(); ++k) dt.push_back(times[k] - times[k - 1]);
  if (dt.empty()) return 0.25;
  std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
  return std::max(0.25, 5.0 * dt[dt.size() / 2]);
}

// Appends (x, y) to a line series, with a break before it when it comes after a gap in time.
struct LineBuilder {
  plot::Series& series;
  double gap_s;
  double last_t = kNaN;
  void add(double t, double x, double y) {
    if (std::isfinite(last_t) && t - last_t > gap_s) {
      series.x.push_back(kNaN);
      series.y.push_back(kNaN);
    }
    series.x.push_back(x);
    series.y.push_back(y);
    last_t = t;
  }
};

plot::Series series(std::string label, const char* colour, plot::SeriesStyle style = plot::SeriesStyle::kLine,
                    double width = 1.5) {
  plot::Series s;
  s.label = std::move(label);
  s.colour = colour;
  s.style = style;
  s.width_px = width;
  return s;
}

std::string counted(const std::string& label, size_t n) { return label + " (" + std::to_string(n) + ")"; }

// ---- trajectory ---------------------------------------------------------------------------------

void addTrajectoryPlots(const Trajectory& trajectory, const Trajectory& ground_truth, const eval::AteResult& ate,
                        double t_first, double t_last, RunPlots& out) {
  // Ground truth over the run's time span (a run of the first N frames covers only part of it).
  std::vector<Vec3> gt_points;
  std::vector<double> gt_times;
  Trajectory gt_sorted = ground_truth;
  std::sort(gt_sorted.begin(), gt_sorted.end(), [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  for (const StampedPose& p : gt_sorted)
    if (p.timestamp >= t_first - 0.5 && p.timestamp <= t_last + 0.5) {
      gt_points.push_back(p.T_w_c.translation());
      gt_times.push_back(p.timestamp);
    }
  std::vector<Vec3> est_points;
  std::vector<double> est_times;
  for (const StampedPose& p : trajectory) {
    est_points.push_back(ate.T_gt_est * p.T_w_c.translation());
    est_times.push_back(p.timestamp);
  }
  // The views: the two ground-truth axes along which the camera moved most (top), the most and
  // the least (side). TUM's and Bonn's motion-capture worlds are not aligned alike, so the data
  // decides rather than a fixed "z is up".
  std::array<double, 3> extent{0, 0, 0};
  for (int a = 0; a < 3; ++a) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Vec3& p : gt_points.empty() ? est_points : gt_points) {
      lo = std::min(lo, p[a]);
      hi = std::max(hi, p[a]);
    }
    extent[a] = hi >= lo ? hi - lo : 0;
  }
  std::array<int, 3> order{0, 1, 2};
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return extent[a] > extent[b]; });
  const char* names[] = {"x", "y", "z"};
  struct View {
    const char* id;
    const char* name;
    int h, v;
  };
  const View views[] = {{"trajectory_top", "top view", std::min(order[0], order[1]), std::max(order[0], order[1])},
                        {"trajectory_side", "side view", order[0], order[2]}};
  const double gt_gap = gapSeconds(gt_times), est_gap = gapSeconds(est_times);
  for (const View& view : views) {
    plot::Figure figure;
    figure.id = view.id;
    figure.title = std::string("Trajectory, ") + view.name + " (" + names[view.h] + "-" + names[view.v] +
                   "): estimate aligned to the ground truth";
    figure.x_label = std::string(names[view.h]) + " (m, ground-truth world)";
    figure.equal_aspect = true;
    plot::Panel panel;
    panel.y_label = std::string(names[view.v]) + " (m)";
    panel.y_includes_zero = false;
    panel.height_px = view.id == std::string("trajectory_top") ? 640 : 420;
    plot::Series gt = series("ground truth", kGrey, plot::SeriesStyle::kLine, 1.5);
    LineBuilder gt_line{gt, gt_gap};
    for (size_t k = 0; k < gt_points.size(); ++k) gt_line.add(gt_times[k], gt_points[k][view.h], gt_points[k][view.v]);
    plot::Series est = series("estimate (main map)", kBlue, plot::SeriesStyle::kLine, 1.5);
    LineBuilder est_line{est, est_gap};
    for (size_t k = 0; k < est_points.size(); ++k) est_line.add(est_times[k], est_points[k][view.h], est_points[k][view.v]);
    plot::Series start = series("start", kGreen, plot::SeriesStyle::kPoints, 5);
    if (!est_points.empty()) {
      start.x.push_back(est_points.front()[view.h]);
      start.y.push_back(est_points.front()[view.v]);
    }
    panel.series = {gt, est, start};
    figure.panels.push_back(panel);
    RunPlot plot;
    plot.id = figure.id;
    plot.title = figure.title;
    plot.caption = "The main map's camera positions (CameraTrajectory.txt, " + std::to_string(est_points.size()) +
                   " poses) moved by the rigid transform the ATE uses (T_gt_est, fitted over " +
                   std::to_string(ate.matched) + " matched poses), over the ground truth of the same time span; axes " +
                   names[view.h] + " and " + names[view.v] +
                   " of the ground-truth world, one metre as long on both. Lines are broken where poses are missing.";
    plot.svg = plot::renderSvg(figure);
    out.plots.push_back(std::move(plot));
  }
}

// ---- errors over time ---------------------------------------------------------------------------

void addAtePlot(const json& report, const eval::AteResult& ate, double t0, RunPlots& out) {
  plot::Figure figure;
  figure.id = "ate_over_time";
  figure.title = "ATE per frame (main map) with tracking losses, relocalisations, new maps and merges";
  figure.x_label = "time since the first frame (s)";
  plot::Panel errors;
  errors.y_label = "ATE (m)";
  errors.height_px = 260;
  plot::Series ate_series = series("ATE of the frame", kBlue, plot::SeriesStyle::kLine, 1.2);
  std::vector<double> times;
  for (const eval::PoseError& e : ate.per_pose) times.push_back(e.timestamp);
  LineBuilder line{ate_series, gapSeconds(times)};
  for (const eval::PoseError& e : ate.per_pose) line.add(e.timestamp, e.timestamp - t0, e.error_m);
  errors.series.push_back(ate_series);

  const RunEvents events = runEvents(report);
  const auto markers = [t0](std::string label, const char* colour, bool dashed, const std::vector<double>& times_s) {
    plot::EventMarkers m;
    m.label = counted(label, times_s.size());
    m.colour = colour;
    m.dashed = dashed;
    for (const double t : times_s) m.x.push_back(t - t0);
    return m;
  };
  errors.events = {markers("tracking lost", kRed, false, events.losses),
                   markers("regained / relocalised", kGreen, false, events.regained),
                   markers("new map", kPurple, true, events.new_maps), markers("maps merged", kOrange, true, events.merges)};
  figure.panels.push_back(errors);

  // Which map each frame was tracked in (-1: no pose): new maps and gaps at a glance.
  plot::Panel maps;
  maps.y_label = "map";
  maps.height_px = 110;
  maps.y_includes_zero = false;
  maps.y_tick_step = 1;
  plot::Series tracked = series("tracked by features", kBlue, plot::SeriesStyle::kPoints, 1.8);
  plot::Series predicted = series("pose predicted (motion model)", kOrange, plot::SeriesStyle::kPoints, 1.8);
  plot::Series none = series("no pose", kRed, plot::SeriesStyle::kPoints, 1.8);
  double max_map = 0;
  for (const json& f : perFrame(report)) {
    const double t = number(f, "timestamp") - t0;
    const double map = number(f, "map", -1);
    max_map = std::max(max_map, map);
    plot::Series& target = flag(f, "tracked") ? tracked : flag(f, "predicted") ? predicted : none;
    target.x.push_back(t);
    target.y.push_back(map >= 0 ? map : -1);
  }
  maps.series = {tracked, predicted, none};
  maps.y_range = plot::Range{-1.5, max_map + 0.5};
  figure.panels.push_back(maps);

  RunPlot plot;
  plot.id = figure.id;
  plot.title = figure.title;
  plot.caption = "Top: |ground truth - T_gt_est * estimate| of every frame of the main map (RMSE " +
                 fixed(ate.translation_m.rmse, 4) + " m, median " + fixed(ate.translation_m.median, 4) + " m, max " +
                 fixed(ate.translation_m.max, 4) + " m over " + std::to_string(ate.matched) +
                 " poses); vertical lines: tracking lost (a frame not tracked by features after one that was), "
                 "regained (tracked again without a new map: relocalisation or the search around the last pose), a "
                 "new map started (the first included), two maps merged (at the recognised keyframe's time). "
                 "Bottom: the map each frame was tracked in; -1 = no pose.";
  plot.svg = plot::renderSvg(figure);
  out.plots.push_back(std::move(plot));
}

void addRpePlot(const eval::RpeResult& rpe, double t0, RunPlots& out) {
  plot::Figure figure;
  figure.id = "rpe_over_time";
  figure.title = "RPE over time (" + fixed(rpe.delta_s, 1) + " s windows, main map)";
  figure.x_label = "start of the window, time since the first frame (s)";
  plot::Panel translation, rotation;
  translation.y_label = "translation (m per " + fixed(rpe.delta_s, 1) + " s)";
  rotation.y_label = "rotation (deg per " + fixed(rpe.delta_s, 1) + " s)";
  translation.height_px = rotation.height_px = 200;
  plot::Series t = series("translational RPE", kBlue, plot::SeriesStyle::kLine, 1.2);
  plot::Series r = series("rotational RPE", kPurple, plot::SeriesStyle::kLine, 1.2);
  std::vector<double> times;
  for (const eval::RpePair& p : rpe.per_pair) times.push_back(p.start_time);
  const double gap = gapSeconds(times);
  LineBuilder tl{t, gap}, rl{r, gap};
  for (const eval::RpePair& p : rpe.per_pair) {
    tl.add(p.start_time, p.start_time - t0, p.translation_m);
    rl.add(p.start_time, p.start_time - t0, p.rotation_deg);
  }
  translation.series.push_back(t);
  rotation.series.push_back(r);
  figure.panels = {translation, rotation};
  RunPlot plot;
  plot.id = figure.id;
  plot.title = figure.title;
  plot.caption = "Relative pose error of each pair of main-map poses about " + fixed(rpe.delta_s, 1) +
                 " s apart (" + std::to_string(rpe.pairs) + " pairs; RMSE " + fixed(rpe.translation_m.rmse, 4) +
                 " m and " + fixed(rpe.rotation_deg.rmse, 3) +
                 " deg): drift over a short window, insensitive to errors made earlier.";
  plot.svg = plot::renderSvg(figure);
  out.plots.push_back(std::move(plot));
}

// ---- per-frame statistics -----------------------------------------------------------------------

void addDynamicPlot(const json& report, double t0, RunPlots& out) {
  const json& frames = perFrame(report);
  struct Field {
    const char* key;
    const char* label;
    const char* colour;
    bool dashed;
  };
  const Field fields[] = {{"in_mask", "in the person mask", kPurple, false},
                          {"semantic_removed", "removed by the mask (semantic mode)", kBrown, false},
                          {"stage1_removed", "removed by stage 1 (depth vs previous frames)", kOrange, false},
                          {"free_space_removed", "of those: free-space test outside the mask", kPink, true},
                          {"stage2_removed", "removed by stage 2 (depth vs map points)", kRed, false}};
  plot::Figure figure;
  figure.id = "dynamic_features";
  figure.title = "Dynamic features per frame, by stage, and the age of the mask used";
  figure.x_label = "time since the first frame (s)";
  plot::Panel counts;
  counts.y_label = "features per frame";
  counts.height_px = 240;
  std::string totals;
  for (const Field& field : fields) {
    plot::Series s = series(field.label, field.colour, plot::SeriesStyle::kLine, 1.1);
    s.dashed = field.dashed;
    double sum = 0;
    for (const json& f : frames) {
      s.x.push_back(number(f, "timestamp") - t0);
      s.y.push_back(number(f, field.key));
      sum += std::isfinite(s.y.back()) ? s.y.back() : 0;
    }
    // Kinds that never happened in this mode (e.g. mask removals outside semantic mode) stay out.
    if (sum <= 0 && std::string(field.key) != "stage1_removed" && std::string(field.key) != "stage2_removed") continue;
    totals += std::string(totals.empty() ? "" : ", ") + field.label + " " + fixed(sum, 0);
    counts.series.push_back(std::move(s));
  }
  plot::Panel age;
  age.y_label = "mask age (frames)";
  age.height_px = 120;
  age.empty_note = "no masks (segmentation off, or geometric / off mode)";
  plot::Series a = series("frames between the mask's frame and this one", kGreen, plot::SeriesStyle::kPoints, 1.6);
  size_t with_mask = 0;
  for (const json& f : frames) {
    const double mask_age = number(f, "mask_age", -1);
    a.x.push_back(number(f, "timestamp") - t0);
    a.y.push_back(mask_age >= 0 ? mask_age : kNaN);
    with_mask += mask_age >= 0;
  }
  age.series.push_back(a);
  // Ages are whole frames: integer ticks while they fit (offline runs use each frame's own mask).
  double max_age = 0;
  for (const double v : a.y)
    if (std::isfinite(v)) max_age = std::max(max_age, v);
  if (max_age <= 4) {
    age.y_range = plot::Range{0, std::max(1.0, max_age)};
    age.y_tick_step = 1;
  }
  figure.panels = {counts, age};
  std::string mode = "?";
  if (const json& settings = report.value("settings", json::object()); settings.contains("dynamic") &&
                                                                        settings["dynamic"].is_object() &&
                                                                        settings["dynamic"].contains("mode"))
    mode = settings["dynamic"]["mode"].dump();
  RunPlot plot;
  plot.id = figure.id;
  plot.title = figure.title;
  plot.caption = "dynamic.mode " + mode + ". Totals over the run: " + (totals.empty() ? "none" : totals) +
                 ". In full mode the features in the person mask go to stage 1, which removes those whose depth "
                 "disagrees with the previous frames (plus the free-space test outside the mask); stage 2 removes "
                 "features whose depth disagrees with their map point. Bottom: " +
                 std::to_string(with_mask) + " of " + std::to_string(frames.size()) +
                 " frames had a mask; 0 = the frame's own mask, more = a mask of an older frame carried forward.";
  plot.svg = plot::renderSvg(figure);
  out.plots.push_back(std::move(plot));
}

void addTimingPlot(const json& report, double t0, RunPlots& out) {
  const json& frames = perFrame(report);
  struct Field {
    const char* key;
    const char* label;
    const char* colour;
  };
  // report.json of runs before these fields existed has only tracking_ms (extraction + pose).
  const bool split = !frames.empty() && frames[0].contains("extraction_ms");
  std::vector<Field> fields;
  if (split)
    fields = {{"extraction_ms", "ORB extraction", kBlue},
              {"pose_tracking_ms", "pose tracking and dynamic checks", kGreen},
              {"mask_wait_ms", "waiting for the mask", kOrange},
              {"segmentation_ms", "segmentation (network time of the mask used)", kPurple},
              {"total_ms", "whole frame (processFrame)", kGrey}};
  else
    fields = {{"tracking_ms", "ORB extraction + pose tracking", kBlue},
              {"segmentation_ms", "segmentation (network time of the mask used)", kPurple}};
  plot::Figure figure;
  figure.id = "stage_timings";
  figure.title = "Time per frame of each stage";
  figure.x_label = "time since the first frame (s)";
  std::string medians, cuts;
  // One panel per stage (five lines in one box hide each other), each with its own axis.
  for (const Field& field : fields) {
    plot::Series s = series(field.label, field.colour, plot::SeriesStyle::kLine, 1.0);
    std::vector<double> values;
    for (const json& f : frames) {
      const double v = number(f, field.key);
      s.x.push_back(number(f, "timestamp") - t0);
      s.y.push_back(v >= 0 ? v : kNaN);  // segmentation_ms -1: no mask
      if (v >= 0) values.push_back(v);
    }
    if (values.empty()) continue;
    std::sort(values.begin(), values.end());
    medians += std::string(medians.empty() ? "" : ", ") + field.label + " " + fixed(values[values.size() / 2], 1) + " ms";
    plot::Panel panel;
    panel.y_label = "ms";
    panel.height_px = 90;
    // A few slow frames (the first one, a map merge, a full queue) would flatten every other
    // frame: cut the axis above the 99th percentile and say so.
    const double p99 = values[static_cast<size_t>(0.99 * (values.size() - 1))];
    if (values.back() > 1.5 * p99 && p99 > 0) {
      const double top = plot::niceRange(0, 1.2 * p99).max;
      panel.y_range = plot::Range{0, top};
      const size_t above = static_cast<size_t>(values.end() - std::upper_bound(values.begin(), values.end(), top));
      cuts += " " + std::string(field.label) + ": axis cut at " + fixed(top, 0) + " ms, " + std::to_string(above) +
              " values above, up to " + fixed(values.back(), 0) + " ms.";
    }
    panel.series.push_back(std::move(s));
    figure.panels.push_back(std::move(panel));
  }
  RunPlot plot;
  plot.id = figure.id;
  plot.title = figure.title;
  plot.caption = "Per frame, on the tracking thread (segmentation runs on its own thread; its time is that of the "
                 "mask the frame used). Medians: " +
                 (medians.empty() ? std::string("none") : medians) + "." + cuts;
  plot.svg = plot::renderSvg(figure);
  out.plots.push_back(std::move(plot));
}

}  // namespace

const std::vector<std::string>& runPlotIds() { return kPlotIds; }

RunEvents runEvents(const json& report) {
  RunEvents events;
  bool previous_tracked = false;
  size_t k = 0;
  for (const json& f : perFrame(report)) {
    const double t = number(f, "timestamp");
    const bool tracked = flag(f, "tracked");
    if (flag(f, "new_map")) events.new_maps.push_back(t);
    if (previous_tracked && !tracked) events.losses.push_back(t);
    if (!previous_tracked && tracked && !flag(f, "new_map") && k > 0) events.regained.push_back(t);
    previous_tracked = tracked;
    ++k;
  }
  if (report.is_object() && report.contains("statistics") && report["statistics"].is_object()) {
    const json& atlas = report["statistics"].value("atlas", json::object());
    if (atlas.is_object() && atlas.contains("maps") && atlas["maps"].is_array())
      for (const json& m : atlas["maps"])
        if (m.is_object() && m.contains("merged_into") && m["merged_into"].is_number())
          events.merges.push_back(number(m, "merged_at"));
    std::sort(events.merges.begin(), events.merges.end());
  }
  return events;
}

RunPlots makeRunPlots(const json& report, const Trajectory& trajectory, const Trajectory* ground_truth,
                      const std::string& no_ground_truth_reason) {
  RunPlots out;
  const json& frames = perFrame(report);
  double t_first = kNaN, t_last = kNaN;
  for (const json& f : frames) {
    const double t = number(f, "timestamp");
    if (!std::isfinite(t)) continue;
    if (!std::isfinite(t_first)) t_first = t;
    t_last = t;
  }
  if (!std::isfinite(t_first) && !trajectory.empty()) {
    t_first = trajectory.front().timestamp;
    t_last = trajectory.back().timestamp;
  }
  const double t0 = std::isfinite(t_first) ? t_first : 0.0;

  const auto leaveOut = [&out](const std::vector<std::string>& ids, const std::string& reason) {
    for (const std::string& id : ids) out.left_out.push_back({id, reason});
  };
  const std::vector<std::string> gt_plots = {"trajectory_top", "trajectory_side", "ate_over_time", "rpe_over_time"};
  if (ground_truth == nullptr) {
    leaveOut(gt_plots, "no ground truth: " + (no_ground_truth_reason.empty() ? std::string("none given") : no_ground_truth_reason));
  } else if (trajectory.size() < 3) {
    leaveOut(gt_plots, "the main map has " + std::to_string(trajectory.size()) + " poses (CameraTrajectory.txt): too few to align");
  } else {
    try {
      // The same association and alignment as report.json's ATE and RPE (eval/metrics.hpp).
      const eval::AteResult ate = eval::computeAte(*ground_truth, trajectory);
      addTrajectoryPlots(trajectory, *ground_truth, ate, std::isfinite(t_first) ? t_first : trajectory.front().timestamp,
                         std::isfinite(t_last) ? t_last : trajectory.back().timestamp, out);
      addAtePlot(report, ate, t0, out);
      const eval::RpeResult rpe = eval::computeRpe(*ground_truth, trajectory);
      if (rpe.pairs > 0)
        addRpePlot(rpe, t0, out);
      else
        leaveOut({"rpe_over_time"}, "no RPE pairs: the main map spans less than the 1 s window");
    } catch (const InputError& e) {
      for (const std::string& id : gt_plots)
        if (std::none_of(out.plots.begin(), out.plots.end(), [&](const RunPlot& p) { return p.id == id; }))
          out.left_out.push_back({id, e.what()});
    }
  }
  if (frames.empty()) {
    leaveOut({"dynamic_features", "stage_timings"}, "report.json lists no frames (statistics.per_frame is empty)");
  } else {
    addDynamicPlot(report, t0, out);
    addTimingPlot(report, t0, out);
  }
  // Page order, whatever order they were made in.
  std::stable_sort(out.plots.begin(), out.plots.end(), [](const RunPlot& a, const RunPlot& b) {
    const auto rank = [](const std::string& id) { return std::find(kPlotIds.begin(), kPlotIds.end(), id) - kPlotIds.begin(); };
    return rank(a.id) < rank(b.id);
  });
  return out;
}

std::vector<std::filesystem::path> writeRunPlots(const std::filesystem::path& dir, const RunPlots& plots) {
  std::vector<std::filesystem::path> written;
  for (const RunPlot& plot : plots.plots) {
    written.push_back(dir / plot.fileName());
    writeFileAtomically(written.back(), plot.svg, "plot");
  }
  return written;
}

json toJson(const RunPlots& plots) {
  json files = json::array(), left_out = json::array();
  for (const RunPlot& p : plots.plots) files.push_back(p.fileName());
  for (const LeftOutPlot& p : plots.left_out) left_out.push_back({{"id", p.id}, {"reason", p.reason}});
  return {{"files", files}, {"left_out", left_out}};
}

}  // namespace desslam::report
