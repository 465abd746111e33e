// Where the data a run needs lies (the default vocabulary vocab/*.bin, the camera presets
// config/*.yaml, optionally models/): the folders looked at, in order, and the file found there.
//
// Installed (cmake --install, the .deb), the data is <prefix>/share/desslam, found relative to the
// library or program that holds this code, so a moved prefix still works. In the build tree it is
// the source tree, compiled in, and looked at only while the code runs from that build tree.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace desslam {

// Everything the search depends on, apart so that a test can give its own.
struct DataSearch {
  std::filesystem::path module_file;     // the shared library or program holding this code
  std::string env_data_dir;              // $DESSLAM_DATA_DIR: looked at first when set
  std::string env_source_dir;            // $DESSLAM_SOURCE_DIR (the tests set it): a source tree
  std::filesystem::path lib_to_data;     // relative path from the installed lib dir to share/desslam
  std::filesystem::path bin_to_data;     // the same from the installed bin dir
  std::filesystem::path build_dir;       // the build tree this code was compiled in
  std::filesystem::path source_dir;      // its source tree

  // What this build and this process have (dladdr of this code, the environment, the install
  // layout and folders compiled in).
  static DataSearch current();
};

// The data folders, in order: $DESSLAM_DATA_DIR, $DESSLAM_SOURCE_DIR, <module dir>/<lib_to_data>,
// <module dir>/<bin_to_data>, and source_dir when module_file lies under build_dir. Without
// duplicates; folders need not exist.
std::vector<std::filesystem::path> dataDirectories(const DataSearch& search = DataSearch::current());

// The first <directory>/<relative> that is a regular file, or an empty path. `tried` (optional)
// receives every path looked at, for the error message.
std::filesystem::path findDataFile(const std::filesystem::path& relative,
                                   const std::vector<std::filesystem::path>& directories,
                                   std::vector<std::filesystem::path>* tried = nullptr);

// "\n  <path>" for each path: the list of places looked at in error messages.
std::string listPaths(const std::vector<std::filesystem::path>& paths);

}  // namespace desslam
