// The text files of the datasets and of trajectories (rgb.txt, depth.txt, groundtruth.txt, image
// lists): one record per line; blank lines and lines starting with '#' carry none.
#pragma once

#include <istream>
#include <string>

namespace desslam::io {

// Calls f(line, line_number) for each line holding a record (line numbers 1-based, as editors
// show them). f may modify the line.
template <class F>
void forEachDataLine(std::istream& in, F&& f) {
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    f(line, line_number);
  }
}

}  // namespace desslam::io
