// Where the data a run needs is looked for (core/data_location.hpp): the installed share/desslam
// relative to the library or program, the source tree only from the build tree, the environment
// first; and the first existing file wins.
#include "core/data_location.hpp"

#include <algorithm>

#include <gtest/gtest.h>

#include "support/temp_dir.hpp"

namespace desslam {
namespace {

namespace fs = std::filesystem;

// The layout `cmake --install` makes with CMAKE_INSTALL_LIBDIR = lib/x86_64-linux-gnu.
DataSearch installedLayout(const fs::path& prefix) {
  DataSearch search;
  search.module_file = prefix / "lib" / "x86_64-linux-gnu" / "libdesslam.so.0.1";
  search.lib_to_data = fs::path("..") / ".." / "share" / "desslam";
  search.bin_to_data = fs::path("..") / "share" / "desslam";
  search.build_dir = "/nonexistent/desslam/build";
  search.source_dir = "/nonexistent/desslam";
  return search;
}

TEST(DataLocation, InstalledLibraryFindsShareBesideItsPrefix) {
  test::TempDir dir;
  const fs::path prefix = dir.path() / "prefix";
  const fs::path vocabulary = dir.write("prefix/share/desslam/vocab/v.bin", "vocabulary");
  const std::vector<fs::path> directories = dataDirectories(installedLayout(prefix));
  ASSERT_FALSE(directories.empty());
  EXPECT_EQ(fs::weakly_canonical(directories.front()), fs::weakly_canonical(prefix / "share" / "desslam"));
  EXPECT_EQ(std::find(directories.begin(), directories.end(), fs::path("/nonexistent/desslam")), directories.end())
      << "an installed library must not look at the source tree it was built from";
  EXPECT_EQ(fs::weakly_canonical(findDataFile("vocab/v.bin", directories)), fs::weakly_canonical(vocabulary));
}

TEST(DataLocation, InstalledProgramFindsShareFromBin) {
  test::TempDir dir;
  const fs::path prefix = dir.path() / "prefix";
  dir.write("prefix/share/desslam/config/tum_fr1.yaml", "camera: {}\n");
  DataSearch search = installedLayout(prefix);
  search.module_file = prefix / "bin" / "desslam";
  EXPECT_FALSE(findDataFile("config/tum_fr1.yaml", dataDirectories(search)).empty());
}

TEST(DataLocation, SourceTreeOnlyFromTheBuildTree) {
  test::TempDir dir;
  const fs::path source = dir.path() / "src";
  dir.write("src/vocab/v.bin", "vocabulary");
  DataSearch search = installedLayout(dir.path() / "elsewhere");
  search.source_dir = source;
  search.build_dir = source / "build";
  search.module_file = source / "build" / "src" / "api" / "libdesslam.so.0.1";
  const std::vector<fs::path> from_build = dataDirectories(search);
  EXPECT_EQ(from_build.back(), source.lexically_normal());
  EXPECT_FALSE(findDataFile("vocab/v.bin", from_build).empty());

  search.module_file = dir.path() / "elsewhere" / "lib" / "libdesslam.so.0.1";  // an installed copy
  std::vector<fs::path> tried;
  EXPECT_TRUE(findDataFile("vocab/v.bin", dataDirectories(search), &tried).empty());
  for (const fs::path& path : tried) EXPECT_NE(path, (source / "vocab" / "v.bin").lexically_normal());
}

TEST(DataLocation, EnvironmentComesFirstAndTheFirstExistingFileWins) {
  test::TempDir dir;
  const fs::path prefix = dir.path() / "prefix";
  dir.write("prefix/share/desslam/vocab/v.bin", "installed");
  const fs::path override_file = dir.write("override/vocab/v.bin", "override");
  DataSearch search = installedLayout(prefix);
  search.env_data_dir = (dir.path() / "override").string();
  search.env_source_dir = (dir.path() / "source-from-env").string();
  const std::vector<fs::path> directories = dataDirectories(search);
  ASSERT_GE(directories.size(), 3u);
  EXPECT_EQ(directories[0], dir.path() / "override");
  EXPECT_EQ(directories[1], dir.path() / "source-from-env");
  EXPECT_EQ(findDataFile("vocab/v.bin", directories), override_file.lexically_normal());
}

TEST(DataLocation, TriedListsEveryPlaceWhenNothingIsFound) {
  test::TempDir dir;
  DataSearch search = installedLayout(dir.path() / "prefix");
  search.env_data_dir = (dir.path() / "a").string();
  const std::vector<fs::path> directories = dataDirectories(search);
  std::vector<fs::path> tried;
  EXPECT_TRUE(findDataFile("vocab/missing.bin", directories, &tried).empty());
  ASSERT_EQ(tried.size(), directories.size());
  for (size_t i = 0; i < tried.size(); ++i) EXPECT_EQ(tried[i], directories[i] / "vocab" / "missing.bin");
  const std::string listed = listPaths(tried);
  for (const fs::path& path : tried) EXPECT_NE(listed.find(path.string()), std::string::npos) << listed;
}

TEST(DataLocation, NoDuplicatesWhenLibAndBinLeadToTheSameFolder) {
  DataSearch search = installedLayout("/opt/desslam");
  search.lib_to_data = fs::path("..") / "share" / "desslam";  // lib/ and bin/ are siblings
  search.module_file = "/opt/desslam/lib/libdesslam.so.0.1";
  search.bin_to_data = fs::path("..") / "share" / "desslam";
  const std::vector<fs::path> directories = dataDirectories(search);
  EXPECT_EQ(std::count(directories.begin(), directories.end(), fs::path("/opt/desslam/share/desslam")), 1);
}

TEST(DataLocation, CurrentProcessFindsTheShippedVocabularyFromTheBuildTree) {
  const DataSearch search = DataSearch::current();
  EXPECT_FALSE(search.module_file.empty()) << "dladdr or /proc/self/exe should name this test program";
  DataSearch without_environment = search;
  without_environment.env_data_dir.clear();
  without_environment.env_source_dir.clear();
  std::vector<fs::path> tried;
  EXPECT_FALSE(findDataFile("vocab/desslam_orb_k10l5.bin", dataDirectories(without_environment), &tried).empty())
      << "the test runs from the build tree, so the source tree's vocab/ must be found; looked at:" << listPaths(tried);
}

}  // namespace
}  // namespace desslam
