// Exit statuses of the desslam program, the same for every sub-command (README "Exit codes").
#pragma once

namespace desslam::exit_code {

inline constexpr int kOk = 0;
inline constexpr int kBadInput = 1;        // bad input data or configuration (InputError, ConfigError)
inline constexpr int kUsage = 2;           // bad command line (unknown option, missing argument)
inline constexpr int kNothingTracked = 3;  // `run`: no frame was tracked (outputs and report written)
inline constexpr int kOutputError = 4;     // an output could not be written (no space, no permission)
inline constexpr int kInternalError = 5;   // a pipeline thread or stage failed unexpectedly
inline constexpr int kInterruptedBase = 128;  // `run` stopped by signal N (SIGINT, SIGTERM, SIGHUP): 128 + N

inline constexpr int interrupted(int signal_number) { return kInterruptedBase + signal_number; }

}  // namespace desslam::exit_code
