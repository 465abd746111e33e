// Trajectory evaluation in one include: association, rigid alignment, ATE/RPE, reports.
#pragma once

#include "eval/alignment.hpp"    // IWYU pragma: export
#include "eval/association.hpp"  // IWYU pragma: export
#include "eval/metrics.hpp"      // IWYU pragma: export
#include "eval/report.hpp"       // IWYU pragma: export
