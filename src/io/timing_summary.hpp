// Summaries of measured times for report.json (the pipeline's stage timings, the program's
// real-time lag).
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

namespace desslam::io {

// Median, 95th percentile, mean and count of a series (0 when empty).
nlohmann::json summarizeMilliseconds(std::vector<double> values);

}  // namespace desslam::io
