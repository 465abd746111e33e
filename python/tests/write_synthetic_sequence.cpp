// desslam_write_synthetic <dir> <frames>: writes the project's synthetic static room (the frames
// the C++ system tests track) as a TUM-layout sequence in <dir>/sequence and its camera config in
// <dir>/config.yaml. Built only with the tests, for the Python tests (python/tests/).
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "system/system_support.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s <dir> <frames>\n", argv[0]);
    return 2;
  }
  try {
    const std::filesystem::path dir = argv[1];
    desslam::test::writeSyntheticSequence(dir / "sequence", std::stoi(argv[2]));
    std::ofstream config(dir / "config.yaml");
    config << desslam::test::syntheticConfigYaml();
    if (!config.flush()) throw std::runtime_error("cannot write " + (dir / "config.yaml").string());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
