// What a plot shows, apart from how it is drawn (plot/svg.hpp draws it): series of (x, y) values,
// vertical event markers, panels with their own y axis stacked over one x axis.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace desslam::plot {

struct Range {
  double min = 0, max = 1;
};

enum class SeriesStyle { kLine, kPoints };

// y[k] at x[k] (equal lengths). A non-finite value breaks a line there (a gap: no pose, no
// value) and is never drawn.
struct Series {
  std::string label;  // legend text; empty: not in the legend
  std::string colour = "#1f77b4";  // an SVG colour
  SeriesStyle style = SeriesStyle::kLine;
  double width_px = 1.5;  // line width, or point radius
  bool dashed = false;
  std::vector<double> x, y;
};

// Vertical lines across a panel at each x (events: tracking lost, a new map, a merge), one
// legend entry for them all.
struct EventMarkers {
  std::string label;
  std::string colour = "#d62728";
  bool dashed = false;
  std::vector<double> x;
};

// One plot box with its own y axis.
struct Panel {
  std::string y_label;
  std::vector<Series> series;
  std::vector<EventMarkers> events;
  std::optional<Range> y_range;  // fixed; otherwise the data's range, widened to nice ticks
  bool y_includes_zero = true;   // data range: start the axis at 0 (errors, counts, times)
  std::optional<double> y_tick_step;  // e.g. 1 for ids; otherwise a nice step for the range
  double height_px = 220;        // of the plot box (ignored with Figure::equal_aspect)
  std::string empty_note = "no data";  // written in the box when no series has a finite point
};

// A titled figure: panels stacked top to bottom sharing the x axis (its label under the last).
// equal_aspect: one metre is as long on screen along x as along y (top and side views of a
// trajectory); the box's height then follows the data's proportions.
struct Figure {
  std::string id;  // the SVG's id attribute (also the file stem where it is saved)
  std::string title;
  std::string x_label;
  std::optional<Range> x_range;  // fixed; otherwise all panels' data, widened to nice ticks
  bool x_includes_zero = false;
  bool equal_aspect = false;
  double width_px = 900;
  std::vector<Panel> panels;
};

}  // namespace desslam::plot
