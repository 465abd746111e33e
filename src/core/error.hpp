// Error types: every message names the file or key at fault and says how to fix it.
#pragma once

#include <exception>
#include <stdexcept>
#include <string>

namespace desslam {

// A bad configuration value or key (message names the key, e.g. "orb.num_levels").
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Bad input data: missing folder/file, unreadable image, wrong depth format, empty list.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// An output that could not be written (no space, no permission, not a folder): the message names
// the file and the system's reason (strerror). Nothing half-written is left under the file's name.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A pipeline worker thread (local mapping, loop closing, global BA, dense mapping) failed: its
// exception, caught in the thread, handed to the thread that drives the pipeline. what() names the
// thread and carries the original message; cause() is the original exception.
class WorkerError : public std::runtime_error {
 public:
  WorkerError(const std::string& what, std::exception_ptr cause) : std::runtime_error(what), cause_(std::move(cause)) {}
  const std::exception_ptr& cause() const { return cause_; }

 private:
  std::exception_ptr cause_;
};

// The message of an exception_ptr's exception ("unknown exception" for a non-std one).
inline std::string exceptionMessage(const std::exception_ptr& error) {
  try {
    if (error) std::rethrow_exception(error);
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown exception";
  }
  return {};
}

}  // namespace desslam
