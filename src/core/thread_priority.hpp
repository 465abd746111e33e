// Background work in real-time mode yields the CPU to tracking: on a 2-core machine the network
// and the dense map would otherwise keep tracking from following a 30 Hz camera.
#pragma once

namespace desslam {

// Raises the calling thread's nice value by `increment` (Linux: nice is per thread). Best effort:
// returns false when the system refuses, and the thread simply keeps its priority.
bool lowerCurrentThreadPriority(int increment);

}  // namespace desslam
