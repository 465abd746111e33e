#include <cmath>
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "plot/svg.hpp"
#include "support/expect_contains.hpp"
#include "support/xml_check.hpp"

namespace desslam::plot {
namespace {

size_t count(const std::string& text, const std::string& part) {
  size_t n = 0;
  for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + part.size())) ++n;
  return n;
}

Figure twoPanelFigure() {
  Figure f;
  f.id = "errors";
  f.title = "Errors <per frame> & events";
  f.x_label = "time (s)";
  Panel top;
  top.y_label = "ATE (m)";
  Series s;
  s.label = "ATE";
  s.x = {0, 1, 2, 3, 4, 5};
  s.y = {0.01, 0.02, std::nan(""), 0.04, 0.05, 0.03};  // a gap after the second point
  top.series.push_back(s);
  EventMarkers lost;
  lost.label = "tracking lost (2)";
  lost.x = {2.5, 99.0};  // the second lies outside a fixed x range below
  top.events.push_back(lost);
  Panel bottom;
  bottom.y_label = "map";
  Series points;
  points.label = "tracked";
  points.style = SeriesStyle::kPoints;
  points.x = {0, 1, 2};
  points.y = {0, 0, 1};
  bottom.series.push_back(points);
  f.panels = {top, bottom};
  f.x_range = Range{0, 5};
  return f;
}

TEST(PlotSvg, IsWellFormedWithEscapedTextAndTheFigureNamed) {
  const std::string svg = renderSvg(twoPanelFigure());
  EXPECT_EQ(test::xmlProblem(svg), "") << svg;
  EXPECT_EQ(svg.rfind("<svg xmlns=\"http://www.w3.org/2000/svg\"", 0), 0u) << "a standalone SVG document";
  EXPECT_CONTAINS(svg, "id=\"errors\"");
  EXPECT_CONTAINS(svg, "<title>Errors &lt;per frame&gt; &amp; events</title>");
  EXPECT_CONTAINS(svg, ">ATE (m)</text>");
  EXPECT_CONTAINS(svg, ">time (s)</text>");
  EXPECT_CONTAINS(svg, ">tracking lost (2)</text>");
  EXPECT_EQ(svg.find("http://", svg.find('>')), std::string::npos) << "no external reference beyond the namespace";
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.find("inf"), std::string::npos);
}

TEST(PlotSvg, AGapBreaksTheLineAndOutOfRangeEventsAreNotDrawn) {
  const std::string svg = renderSvg(twoPanelFigure());
  // Points 0-1 and 3-5 are two polylines; the lone-point rule does not apply.
  EXPECT_EQ(count(svg, "<polyline"), 2u);
  // Three marker circles in the bottom panel plus the legend's one.
  EXPECT_EQ(count(svg, "<circle"), 4u);
  // One event line inside the range (x = 2.5); the one at 99 is left out. Event lines are the
  // only <line> elements with empty attributes after the coordinates.
  const std::regex event_line("<line x1=\"([0-9.]+)\" y1=\"[0-9.]+\" x2=\"\\1\" y2=\"[0-9.]+\" />");
  EXPECT_EQ(std::distance(std::sregex_iterator(svg.begin(), svg.end(), event_line), std::sregex_iterator()), 1);
}

TEST(PlotSvg, SameFigureSameBytes) { EXPECT_EQ(renderSvg(twoPanelFigure()), renderSvg(twoPanelFigure())); }

TEST(PlotSvg, DataIsMappedIntoThePlotBox) {
  Figure f;
  f.id = "box";
  f.width_px = 600;
  Panel p;
  p.height_px = 200;
  p.y_range = Range{0, 10};
  Series s;
  s.x = {0, 10};
  s.y = {0, 10};
  p.series.push_back(s);
  f.panels.push_back(p);
  f.x_range = Range{0, 10};
  const std::string svg = renderSvg(f);
  // The plot box rect, then the line from its bottom-left to its top-right corner.
  const std::regex box("<rect x=\"([0-9.]+)\" y=\"([0-9.]+)\" width=\"([0-9.]+)\" height=\"([0-9.]+)\" fill=\"#fbfbfb\"");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m, box)) << svg;
  const double x = std::stod(m[1]), y = std::stod(m[2]), w = std::stod(m[3]), h = std::stod(m[4]);
  EXPECT_NEAR(h, 200, 0.05);
  char expected[128];
  std::snprintf(expected, sizeof expected, "points=\"%.1f,%.1f %.1f,%.1f\"", x, y + h, x + w, y);
  EXPECT_CONTAINS(svg, expected);
}

TEST(PlotSvg, EqualAspectGivesBothAxesTheSameUnitLength) {
  // A wide trajectory (4 m by 1 m) and a square one: the wide one's box is flatter, and in both
  // the grid spacing per metre is the same on x and y.
  const auto figure = [](double width_m, double height_m) {
    Figure f;
    f.id = "traj";
    f.equal_aspect = true;
    f.width_px = 800;
    Panel p;
    p.height_px = 700;
    p.y_includes_zero = false;
    Series s;
    s.x = {0, width_m, width_m, 0};
    s.y = {0, 0, height_m, height_m};
    p.series.push_back(s);
    f.panels.push_back(p);
    return f;
  };
  const auto heightOf = [](const std::string& svg) {
    std::smatch m;
    std::regex_search(svg, m, std::regex("height=\"([0-9.]+)\" fill=\"#fbfbfb\""));
    return std::stod(m[1]);
  };
  const std::string wide = renderSvg(figure(4, 1)), square = renderSvg(figure(1, 1));
  EXPECT_LT(heightOf(wide), 0.5 * heightOf(square));
  // Pixels per metre from the polyline of the wide one: the rectangle's sides.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(wide, m, std::regex("points=\"([0-9.]+),([0-9.]+) ([0-9.]+),([0-9.]+) ([0-9.]+),([0-9.]+)")));
  const double px_per_m_x = (std::stod(m[3]) - std::stod(m[1])) / 4.0;
  const double px_per_m_y = (std::stod(m[4]) - std::stod(m[6])) / 1.0;
  EXPECT_NEAR(px_per_m_x, px_per_m_y, 0.2);
}

TEST(PlotSvg, EmptyPanelSaysSo) {
  Figure f;
  f.id = "empty";
  Panel p;
  p.empty_note = "no masks";
  Series s;
  s.x = {0, 1};
  s.y = {std::nan(""), std::nan("")};
  p.series.push_back(s);
  f.panels.push_back(p);
  const std::string svg = renderSvg(f);
  EXPECT_EQ(test::xmlProblem(svg), "");
  EXPECT_CONTAINS(svg, ">no masks</text>");
  EXPECT_EQ(count(svg, "<polyline"), 0u);
}

TEST(PlotSvg, LongLegendsWrapInsideTheFigure) {
  Figure f;
  f.id = "legend";
  f.width_px = 400;
  Panel p;
  for (int k = 0; k < 6; ++k) {
    Series s;
    s.label = "a rather long series label " + std::to_string(k);
    s.x = {0, 1};
    s.y = {0, 1};
    p.series.push_back(s);
  }
  f.panels.push_back(p);
  const std::string svg = renderSvg(f);
  // Every legend text starts left of the figure's right edge minus its own estimated width.
  const std::regex label("<text x=\"([0-9.]+)\" y=\"[0-9.]+\">(a rather long series label [0-9])</text>");
  size_t n = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), label); it != std::sregex_iterator(); ++it, ++n)
    EXPECT_LE(std::stod((*it)[1]) + 7.0 * (*it)[2].length(), 400.0) << (*it)[0];
  EXPECT_EQ(n, 6u);
}

TEST(PlotSvg, XmlEscapeCoversTheFiveCharacters) {
  EXPECT_EQ(xmlEscape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&apos;");
  EXPECT_EQ(xmlEscape("plain"), "plain");
}

}  // namespace
}  // namespace desslam::plot
