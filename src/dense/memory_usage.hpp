// Memory figures of this process, for run reports (Linux /proc; 0 where unavailable).
#pragma once

#include <cstddef>

namespace desslam::dense {

// Peak resident set size (VmHWM in /proc/self/status), bytes.
size_t peakResidentBytes();
// Current resident set size (VmRSS), bytes.
size_t residentBytes();

}  // namespace desslam::dense
