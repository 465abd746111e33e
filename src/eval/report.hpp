// Presenting evaluation results: JSON objects (for run reports and `desslam eval --json`) and a
// small human-readable table.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "eval/metrics.hpp"

namespace desslam::eval {

nlohmann::json toJson(const ErrorStats& stats);
nlohmann::json toJson(const AteResult& ate);
nlohmann::json toJson(const RpeResult& rpe);

// ATE row (m), RPE rows (m and deg per delta), and a line with the match and pair counts.
std::string formatTable(const AteResult& ate, const RpeResult& rpe, double max_dt);

}  // namespace desslam::eval
