// report.html: one self-contained page for a run folder (no network needed to open it): the
// figures of report.json in tables, the plots inline as SVG, the dense-map preview embedded as a
// data: URI, the settings, and what is missing and why.
#pragma once

#include <string>
#include <string_view>

#include "report/run_folder.hpp"
#include "report/run_plots.hpp"

namespace desslam::report {

std::string renderHtmlReport(const RunFolder& run, const RunPlots& plots);

// RFC 4648 base64 (with padding), for the embedded PNG.
std::string base64Encode(std::string_view bytes);

}  // namespace desslam::report
