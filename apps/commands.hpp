// Sub-commands of the desslam program. Each lives in its own cmd_<name>.cpp and adds itself
// to the CLI11 app; main.cpp lists them explicitly.
#pragma once

#include <cmath>
#include <exception>
#include <filesystem>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>

#include "core/error.hpp"
#include "core/exit_codes.hpp"

namespace desslam::app {

// Each returns nothing; the command's callback runs when CLI11 selects it and throws on error
// (main prints the message and exits with exitCodeFor(error)).
void registerRunCommand(CLI::App& app);   // cmd_run.cpp
void registerEvalCommand(CLI::App& app);  // cmd_eval.cpp
void registerVocabCommand(CLI::App& app);  // cmd_vocab.cpp
void registerMapCheckCommand(CLI::App& app);  // cmd_mapcheck.cpp
void registerReportCommand(CLI::App& app);    // cmd_report.cpp

// Thrown by a command that has done its work and said what happened (stderr) to end the program
// with a status other than 0 (core/exit_codes.hpp), e.g. `run` after an interruption.
struct ExitStatus {
  int code = exit_code::kOk;
};

// A numeric option's check: a finite number with lo <= value <= hi (CLI::Range lets NaN through,
// and "inf" parses as a number). CLI11 prefixes the message with the option's name, e.g.
// "--tolerance: nan is not a finite number ...", and the command line is refused (exit 2).
inline CLI::Validator finiteRange(double lo, double hi) {
  std::ostringstream description;
  description << "FINITE in [" << lo << " - " << hi << "]";
  return CLI::Validator(
      [lo, hi](std::string& text) -> std::string {
        double value = 0;
        std::size_t used = 0;
        try {
          value = std::stod(text, &used);
        } catch (const std::exception&) {
          return "'" + text + "' is not a number";
        }
        if (used != text.size()) return "'" + text + "' is not a number";
        std::ostringstream msg;
        if (!std::isfinite(value)) {
          msg << text << " is not a finite number: expected " << lo << " <= value <= " << hi;
          return msg.str();
        }
        if (value < lo || value > hi) {
          msg << text << " is out of range: expected " << lo << " <= value <= " << hi;
          return msg.str();
        }
        return {};
      },
      description.str());
}

// The exit status of an error (the same in every sub-command).
inline int exitCodeFor(const std::exception& e) {
  if (dynamic_cast<const InputError*>(&e) != nullptr || dynamic_cast<const ConfigError*>(&e) != nullptr)
    return exit_code::kBadInput;
  if (dynamic_cast<const OutputError*>(&e) != nullptr || dynamic_cast<const std::filesystem::filesystem_error*>(&e) != nullptr)
    return exit_code::kOutputError;
  return exit_code::kInternalError;
}

}  // namespace desslam::app
