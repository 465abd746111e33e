#include "plot/svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "plot/scale.hpp"

namespace desslam::plot {
namespace {

// Layout in pixels. Text is 12 px sans-serif; kCharWidth is a generous average advance for it,
// used only to lay out the legend (SVG cannot measure text).
constexpr double kMarginLeft = 80, kMarginRight = 24, kTitleHeight = 34;
constexpr double kLegendRow = 18, kLegendGap = 6, kTickLabelHeight = 20, kXLabelHeight = 22, kPanelGap = 18;
constexpr double kCharWidth = 7.0;
constexpr double kMinEqualAspectHeight = 160;
constexpr double kEventLane = 9;  // vertical spacing of the event kinds' triangles

std::string num(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", v);
  return std::string(text) == "-0.0" ? "0.0" : text;
}

struct Extent {
  double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return lo > hi; }
};

// A point counts when both of its coordinates are finite.
void addSeriesExtent(const Series& s, Extent& x, Extent& y) {
  for (size_t k = 0; k < std::min(s.x.size(), s.y.size()); ++k)
    if (std::isfinite(s.x[k]) && std::isfinite(s.y[k])) {
      x.add(s.x[k]);
      y.add(s.y[k]);
    }
}

struct LegendItem {
  enum Kind { kLine, kPoint, kEvent } kind = kLine;
  std::string label, colour;
  bool dashed = false;
};

std::vector<LegendItem> legendItems(const Panel& panel) {
  std::vector<LegendItem> items;
  for (const Series& s : panel.series)
    if (!s.label.empty())
      items.push_back({s.style == SeriesStyle::kPoints ? LegendItem::kPoint : LegendItem::kLine, s.label, s.colour, s.dashed});
  for (const EventMarkers& e : panel.events)
    if (!e.label.empty()) items.push_back({LegendItem::kEvent, e.label, e.colour, e.dashed});
  return items;
}

double legendItemWidth(const LegendItem& item) { return 26 + kCharWidth * static_cast<double>(item.label.size()) + 18; }

// Rows of legend items that fit into `width`.
std::vector<std::vector<LegendItem>> legendRows(const std::vector<LegendItem>& items, double width) {
  std::vector<std::vector<LegendItem>> rows;
  double used = 0;
  for (const LegendItem& item : items) {
    const double w = legendItemWidth(item);
    if (rows.empty() || (used + w > width && !rows.back().empty())) {
      rows.emplace_back();
      used = 0;
    }
    rows.back().push_back(item);
    used += w;
  }
  return rows;
}

struct PanelLayout {
  double top = 0;         // where its legend starts
  double box_top = 0, box_height = 0;
  Range x, y;
  double x_step = 1, y_step = 1;
  std::vector<std::vector<LegendItem>> legend;
  bool has_data = false;
};

Range dataRange(const Extent& e, bool include_zero) {
  if (e.empty()) return {0, 1};
  if (include_zero && e.lo == 0 && e.hi == 0) return {0, 1};  // all zero: no negative half
  return {include_zero ? std::min(0.0, e.lo) : e.lo, include_zero ? std::max(0.0, e.hi) : e.hi};
}

// Widens the shorter-in-units side so that a data unit is as long on x as on y.
void equalise(Range& x, Range& y, double width_px, double height_px) {
  const double ux = (x.max - x.min) / width_px, uy = (y.max - y.min) / height_px;
  if (ux > uy) {
    const double half = 0.5 * ux * height_px, mid = 0.5 * (y.min + y.max);
    y = {mid - half, mid + half};
  } else {
    const double half = 0.5 * uy * width_px, mid = 0.5 * (x.min + x.max);
    x = {mid - half, mid + half};
  }
}

void text(std::ostringstream& out, double x, double y, const std::string& s, const std::string& attributes = "") {
  out << "<text x=\"" << num(x) << "\" y=\"" << num(y) << "\"" << (attributes.empty() ? "" : " " + attributes) << ">"
      << xmlEscape(s) << "</text>\n";
}

void line(std::ostringstream& out, double x1, double y1, double x2, double y2, const std::string& attributes) {
  out << "<line x1=\"" << num(x1) << "\" y1=\"" << num(y1) << "\" x2=\"" << num(x2) << "\" y2=\"" << num(y2) << "\" "
      << attributes << "/>\n";
}

std::string strokeAttributes(const std::string& colour, double width, bool dashed) {
  return "stroke=\"" + xmlEscape(colour) + "\" stroke-width=\"" + num(width) + "\"" +
         (dashed ? " stroke-dasharray=\"5 3\"" : "");
}

void drawLegend(std::ostringstream& out, const std::vector<std::vector<LegendItem>>& rows, double left, double top) {
  for (size_t r = 0; r < rows.size(); ++r) {
    double x = left;
    const double y = top + kLegendRow * static_cast<double>(r) + 12;
    for (const LegendItem& item : rows[r]) {
      if (item.kind == LegendItem::kLine)
        line(out, x, y - 4, x + 20, y - 4, strokeAttributes(item.colour, 2.5, item.dashed));
      else if (item.kind == LegendItem::kPoint)
        out << "<circle cx=\"" << num(x + 10) << "\" cy=\"" << num(y - 4) << "\" r=\"3.5\" fill=\"" << xmlEscape(item.colour)
            << "\"/>\n";
      else {
        line(out, x + 10, y - 12, x + 10, y + 3, strokeAttributes(item.colour, 1.5, item.dashed));
        out << "<path d=\"M" << num(x + 6) << "," << num(y - 12) << "h8l-4,7z\" fill=\"" << xmlEscape(item.colour) << "\"/>\n";
      }
      text(out, x + 26, y, item.label);
      x += legendItemWidth(item);
    }
  }
}

void drawSeries(std::ostringstream& out, const Series& s, const LinearScale& sx, const LinearScale& sy) {
  const size_t n = std::min(s.x.size(), s.y.size());
  if (s.style == SeriesStyle::kPoints) {
    out << "<g fill=\"" << xmlEscape(s.colour) << "\">\n";
    for (size_t k = 0; k < n; ++k)
      if (std::isfinite(s.x[k]) && std::isfinite(s.y[k]))
        out << "<circle cx=\"" << num(sx(s.x[k])) << "\" cy=\"" << num(sy(s.y[k])) << "\" r=\"" << num(s.width_px)
            << "\"/>\n";
    out << "</g>\n";
    return;
  }
  // One polyline per run of finite points (a non-finite value is a gap).
  out << "<g fill=\"none\" stroke-linejoin=\"round\" " << strokeAttributes(s.colour, s.width_px, s.dashed) << ">\n";
  std::string points;
  size_t in_run = 0;
  double last_x = 0, last_y = 0;
  const auto flush = [&] {
    if (in_run >= 2) out << "<polyline points=\"" << points << "\"/>\n";
    // A lone point between gaps would be invisible as a line: a dot of the line's width.
    if (in_run == 1)
      out << "<circle cx=\"" << num(last_x) << "\" cy=\"" << num(last_y) << "\" r=\"" << num(std::max(1.0, s.width_px))
          << "\" fill=\"" << xmlEscape(s.colour) << "\" stroke=\"none\"/>\n";
    points.clear();
    in_run = 0;
  };
  for (size_t k = 0; k < n; ++k) {
    if (!std::isfinite(s.x[k]) || !std::isfinite(s.y[k])) {
      flush();
      continue;
    }
    last_x = sx(s.x[k]);
    last_y = sy(s.y[k]);
    if (in_run > 0) points += ' ';
    points += num(last_x);
    points += ',';
    points += num(last_y);
    ++in_run;
  }
  flush();
  out << "</g>\n";
}

}  // namespace

std::string xmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string renderSvg(const Figure& figure) {
  const double width = std::max(figure.width_px, kMarginLeft + kMarginRight + 100);
  const double box_width = width - kMarginLeft - kMarginRight;

  // The x range: fixed, or every panel's data.
  Extent x_extent;
  std::vector<Extent> y_extents(figure.panels.size());
  for (size_t p = 0; p < figure.panels.size(); ++p)
    for (const Series& s : figure.panels[p].series) addSeriesExtent(s, x_extent, y_extents[p]);
  for (size_t p = 0; p < figure.panels.size(); ++p)
    for (const EventMarkers& e : figure.panels[p].events)
      for (const double x : e.x) x_extent.add(x);
  const int x_ticks = std::max(3, static_cast<int>(box_width / 90));  // about one per 90 px
  const Range x_data = dataRange(x_extent, figure.x_includes_zero);
  const Range x_range = figure.x_range ? *figure.x_range : niceRange(x_data.min, x_data.max, x_ticks);

  std::vector<PanelLayout> layouts(figure.panels.size());
  double y_cursor = kTitleHeight;
  for (size_t p = 0; p < figure.panels.size(); ++p) {
    const Panel& panel = figure.panels[p];
    PanelLayout& L = layouts[p];
    L.top = y_cursor;
    L.legend = legendRows(legendItems(panel), box_width);
    L.box_top = L.top + kLegendRow * static_cast<double>(L.legend.size()) + (L.legend.empty() ? 0 : kLegendGap);
    L.has_data = !y_extents[p].empty();
    const Range y_data = dataRange(y_extents[p], panel.y_includes_zero);
    const int y_ticks = std::max(3, static_cast<int>(std::max(40.0, panel.height_px) / 45));  // one per 45 px
    L.y = panel.y_range ? *panel.y_range : niceRange(y_data.min, y_data.max, y_ticks);
    L.x = x_range;
    L.box_height = std::max(40.0, panel.height_px);
    if (figure.equal_aspect) {
      // The data with a small margin (no widening to ticks: that would waste a map's space); the
      // box takes its proportions within limits, and the rest is made equal by widening.
      const auto padded = [](const Extent& e) {
        if (e.empty()) return Range{0, 1};
        const double pad = std::max(0.04 * (e.hi - e.lo), 0.01);
        return Range{e.lo - pad, e.hi + pad};
      };
      L.x = figure.x_range ? *figure.x_range : padded(x_extent);
      if (!panel.y_range) L.y = padded(y_extents[p]);
      const double aspect = (L.y.max - L.y.min) / std::max(1e-12, L.x.max - L.x.min);
      L.box_height = std::clamp(box_width * aspect, kMinEqualAspectHeight, std::max(kMinEqualAspectHeight, panel.height_px));
      equalise(L.x, L.y, box_width, L.box_height);
    }
    L.x_step = niceStep(L.x.min, L.x.max, x_ticks);
    if (panel.y_tick_step && *panel.y_tick_step > 0)
      L.y_step = *panel.y_tick_step;
    else  // at least about 5 ticks, so that a flat box (a side view) still has 2 or 3 labels
      L.y_step = niceStep(L.y.min, L.y.max, std::max(5, static_cast<int>(L.box_height / 45)));
    y_cursor = L.box_top + L.box_height + kTickLabelHeight + (p + 1 == figure.panels.size() ? kXLabelHeight : kPanelGap);
  }
  const double height = y_cursor + 8;

  std::ostringstream out;
  out << "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" id=\"" << xmlEscape(figure.id) << "\" width=\""
      << num(width) << "\" height=\"" << num(height) << "\" viewBox=\"0 0 " << num(width) << " " << num(height)
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  out << "<title>" << xmlEscape(figure.title) << "</title>\n";
  out << "<rect x=\"0\" y=\"0\" width=\"" << num(width) << "\" height=\"" << num(height) << "\" fill=\"#ffffff\"/>\n";
  text(out, kMarginLeft, 22, figure.title, "font-size=\"15\" font-weight=\"bold\"");

  for (size_t p = 0; p < figure.panels.size(); ++p) {
    const Panel& panel = figure.panels[p];
    const PanelLayout& L = layouts[p];
    const double left = kMarginLeft, right = kMarginLeft + box_width, top = L.box_top, bottom = L.box_top + L.box_height;
    const LinearScale sx{L.x.min, L.x.max, left, right};
    const LinearScale sy{L.y.min, L.y.max, bottom, top};
    const std::string clip_id = figure.id + "-clip-" + std::to_string(p);

    drawLegend(out, L.legend, left, L.top);
    out << "<clipPath id=\"" << xmlEscape(clip_id) << "\"><rect x=\"" << num(left) << "\" y=\"" << num(top)
        << "\" width=\"" << num(box_width) << "\" height=\"" << num(L.box_height) << "\"/></clipPath>\n";
    out << "<rect x=\"" << num(left) << "\" y=\"" << num(top) << "\" width=\"" << num(box_width) << "\" height=\""
        << num(L.box_height) << "\" fill=\"#fbfbfb\" stroke=\"#888888\"/>\n";

    // Grid and tick labels.
    out << "<g class=\"grid\">\n";
    for (const double t : ticksInside(L.y, L.y_step)) {
      line(out, left, sy(t), right, sy(t), "stroke=\"#e2e2e2\"");
      text(out, left - 6, sy(t) + 4, formatTick(t, L.y_step), "text-anchor=\"end\"");
    }
    for (const double t : ticksInside(L.x, L.x_step)) {
      line(out, sx(t), top, sx(t), bottom, "stroke=\"#e2e2e2\"");
      text(out, sx(t), bottom + 15, formatTick(t, L.x_step), "text-anchor=\"middle\"");
    }
    out << "</g>\n";
    const double label_y = 0.5 * (top + bottom);
    out << "<text x=\"18\" y=\"" << num(label_y) << "\" text-anchor=\"middle\" transform=\"rotate(-90 18 " << num(label_y)
        << ")\">" << xmlEscape(panel.y_label) << "</text>\n";

    out << "<g clip-path=\"url(#" << xmlEscape(clip_id) << ")\">\n";
    // Each kind of event: a faint line across the box and a triangle in its own lane at the top,
    // so that kinds at (nearly) the same time stay apart.
    std::string event_paths;
    for (size_t k = 0; k < panel.events.size(); ++k) {
      const EventMarkers& e = panel.events[k];
      const double lane_y = top + 3 + kEventLane * static_cast<double>(k);
      std::string triangles;
      out << "<g " << strokeAttributes(e.colour, 1.0, e.dashed) << " stroke-opacity=\"0.55\">\n";
      for (const double x : e.x)
        if (std::isfinite(x) && x >= L.x.min && x <= L.x.max) {
          line(out, sx(x), top, sx(x), bottom, "");
          triangles += 'M';
          triangles += num(sx(x) - 4);
          triangles += ',';
          triangles += num(lane_y);
          triangles += "h8l-4,7z";
        }
      out << "</g>\n";
      if (!triangles.empty()) event_paths += "<path d=\"" + triangles + "\" fill=\"" + xmlEscape(e.colour) + "\"/>\n";
    }
    for (const Series& s : panel.series) drawSeries(out, s, sx, sy);
    out << "</g>\n" << event_paths;  // the triangles unclipped: one at the box's edge stays whole
    if (!L.has_data) text(out, 0.5 * (left + right), label_y, panel.empty_note, "text-anchor=\"middle\" fill=\"#666666\"");
  }
  if (!layouts.empty()) {
    const PanelLayout& last = layouts.back();
    text(out, kMarginLeft + 0.5 * box_width, last.box_top + last.box_height + kTickLabelHeight + 16, figure.x_label,
         "text-anchor=\"middle\"");
  }
  out << "</svg>\n";
  return out.str();
}

}  // namespace desslam::plot
