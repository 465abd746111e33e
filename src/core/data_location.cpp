#include "core/data_location.hpp"

#include <dlfcn.h>
#include <link.h>

#include <algorithm>
#include <cstdlib>
#include <system_error>

namespace desslam {

namespace fs = std::filesystem;

namespace {

std::string environment(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr ? std::string(value) : std::string();
}

// The file of the shared library or program this function was linked into. dladdr names a shared
// library by the path it was loaded from; the main program has an empty name there, so it is
// read from /proc/self/exe.
fs::path moduleFile() {
  Dl_info info{};
  link_map* map = nullptr;
  if (::dladdr1(reinterpret_cast<void*>(&moduleFile), &info, reinterpret_cast<void**>(&map), RTLD_DL_LINKMAP) != 0 &&
      map != nullptr && map->l_name != nullptr && map->l_name[0] != '\0') {
    return fs::path(map->l_name);
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe;
}

fs::path normalised(const fs::path& path) {
  std::error_code ec;
  const fs::path canonical = fs::weakly_canonical(path, ec);
  return (ec ? path : canonical).lexically_normal();
}

// Whether `path` lies in `folder` (both made absolute and free of symbolic links first).
bool isInside(const fs::path& path, const fs::path& folder) {
  if (path.empty() || folder.empty()) return false;
  const fs::path relative = normalised(path).lexically_relative(normalised(folder));
  return !relative.empty() && *relative.begin() != "..";
}

}  // namespace

DataSearch DataSearch::current() {
  DataSearch search;
  search.module_file = moduleFile();
  search.env_data_dir = environment("DESSLAM_DATA_DIR");
  search.env_source_dir = environment("DESSLAM_SOURCE_DIR");
#ifdef DESSLAM_LIB_TO_DATA
  search.lib_to_data = DESSLAM_LIB_TO_DATA;
#endif
#ifdef DESSLAM_BIN_TO_DATA
  search.bin_to_data = DESSLAM_BIN_TO_DATA;
#endif
#ifdef DESSLAM_BUILD_TREE
  search.build_dir = DESSLAM_BUILD_TREE;
#endif
#ifdef DESSLAM_SOURCE_TREE
  search.source_dir = DESSLAM_SOURCE_TREE;
#endif
  return search;
}

std::vector<fs::path> dataDirectories(const DataSearch& search) {
  std::vector<fs::path> directories;
  const auto add = [&directories](const fs::path& directory) {
    if (directory.empty()) return;
    const fs::path clean = directory.lexically_normal();
    if (std::find(directories.begin(), directories.end(), clean) == directories.end()) directories.push_back(clean);
  };
  add(search.env_data_dir);
  add(search.env_source_dir);
  if (!search.module_file.empty()) {
    const fs::path module_dir = normalised(search.module_file).parent_path();
    if (!search.lib_to_data.empty()) add(module_dir / search.lib_to_data);
    if (!search.bin_to_data.empty()) add(module_dir / search.bin_to_data);
  }
  // The source tree only for code running from its build tree: an installed copy must not
  // depend on a source folder that may since have changed or gone.
  if (isInside(search.module_file, search.build_dir)) add(search.source_dir);
  return directories;
}

fs::path findDataFile(const fs::path& relative, const std::vector<fs::path>& directories,
                      std::vector<fs::path>* tried) {
  if (tried != nullptr) tried->clear();
  for (const fs::path& directory : directories) {
    const fs::path candidate = directory / relative;
    if (tried != nullptr) tried->push_back(candidate);
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return candidate.lexically_normal();
  }
  return {};
}

std::string listPaths(const std::vector<fs::path>& paths) {
  std::string out;
  for (const fs::path& path : paths) out += "\n  " + path.string();
  return out;
}

}  // namespace desslam
