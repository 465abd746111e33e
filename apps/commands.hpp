// Sub-commands of the desslam program. Each lives in its own cmd_<name>.cpp and adds itself
// to the CLI11 app; main.cpp lists them explicitly.
#pragma once

#include <CLI/CLI.hpp>

namespace desslam::app {

// Each returns nothing; the command's callback runs when CLI11 selects it and throws on error
// (main prints the message and exits with status 1).
void registerRunCommand(CLI::App& app);   // cmd_run.cpp
void registerEvalCommand(CLI::App& app);  // cmd_eval.cpp
void registerVocabCommand(CLI::App& app);  // cmd_vocab.cpp
void registerMapCheckCommand(CLI::App& app);  // cmd_mapcheck.cpp

}  // namespace desslam::app
