// Draws a plot::Figure as one standalone SVG document (SVG 1.1, no scripts, no external
// references, no fonts beyond the generic "sans-serif"): valid as a file of its own and inline
// in an HTML page. The same figure always gives the same bytes.
#pragma once

#include <string>
#include <string_view>

#include "plot/figure.hpp"

namespace desslam::plot {

std::string renderSvg(const Figure& figure);

// Text for XML character data and attribute values (&, <, >, ", ').
std::string xmlEscape(std::string_view text);

}  // namespace desslam::plot
