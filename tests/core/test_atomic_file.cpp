// The atomic output writer: complete files or none, failures name the file and the system's reason.
#include <sys/resource.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "support/temp_dir.hpp"

namespace desslam {
namespace {

namespace fs = std::filesystem;

std::string readAll(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

size_t filesIn(const fs::path& dir) {
  size_t n = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++n;
  return n;
}

// The message of the OutputError `f` throws (fails the test when it throws nothing).
template <class F>
std::string outputError(F&& f) {
  try {
    f();
  } catch (const OutputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an OutputError";
  return {};
}

TEST(AtomicFile, WritesTheWholeFileAndLeavesNoTemporary) {
  const test::TempDir dir;
  const std::string text(100000, 'x');
  writeFileAtomically(dir / "a.txt", text, "test file");
  EXPECT_EQ(readAll(dir / "a.txt"), text);
  writeFileAtomically(dir / "a.txt", "second", "test file");  // replaces
  EXPECT_EQ(readAll(dir / "a.txt"), "second");
  EXPECT_EQ(filesIn(dir.path()), 1u);
}

TEST(AtomicFile, TemporaryNameKeepsTheExtension) {
  const fs::path tmp = atomicTempPath("/some/dir/dense_map.ply");
  EXPECT_EQ(tmp.parent_path(), fs::path("/some/dir"));
  EXPECT_EQ(tmp.extension(), ".ply");
  EXPECT_TRUE(isAtomicTempName(tmp.filename().string()));
  EXPECT_FALSE(isAtomicTempName("dense_map.ply"));
}

TEST(AtomicFile, MissingFolderNamesTheFileAndTheReason) {
  const test::TempDir dir;
  const std::string message = outputError([&] { writeFileAtomically(dir / "no" / "a.txt", "x", "test file"); });
  EXPECT_NE(message.find("a.txt"), std::string::npos) << message;
  EXPECT_NE(message.find("No such file or directory"), std::string::npos) << message;
}

// A write that fails half-way (the file-size limit: root ignores permissions, not this) leaves the
// earlier version whole and no temporary file.
TEST(AtomicFile, FailedWriteKeepsTheEarlierVersionAndNoHalfFile) {
  const test::TempDir dir;
  writeFileAtomically(dir / "report.json", "earlier", "report");
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);  // the write fails with EFBIG instead
  rlimit old_limit{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  rlimit limit = old_limit;
  limit.rlim_cur = 4096;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  const std::string message =
      outputError([&] { writeFileAtomically(dir / "report.json", std::string(100000, 'y'), "report"); });
  setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find("report.json"), std::string::npos) << message;
  EXPECT_NE(message.find("File too large"), std::string::npos) << message;
  EXPECT_EQ(readAll(dir / "report.json"), "earlier");
  EXPECT_EQ(filesIn(dir.path()), 1u);
}

TEST(AtomicFile, FailingLibraryWriterLeavesNothing) {
  const test::TempDir dir;
  const std::string message = outputError([&] {
    writeFileAtomicallyVia(dir / "map.ply", "PLY", [](const fs::path& tmp) {
      std::ofstream(tmp) << "half";
      return false;
    });
  });
  EXPECT_NE(message.find("map.ply"), std::string::npos) << message;
  EXPECT_EQ(filesIn(dir.path()), 0u);
  writeFileAtomicallyVia(dir / "map.ply", "PLY", [](const fs::path& tmp) {
    std::ofstream(tmp) << "whole";
    return true;
  });
  EXPECT_EQ(readAll(dir / "map.ply"), "whole");
}

TEST(AtomicFile, WritableFolderIsCreatedAndProbed) {
  const test::TempDir dir;
  requireWritableFolder(dir / "new" / "out", "--out folder");
  EXPECT_TRUE(fs::is_directory(dir / "new" / "out"));
  EXPECT_EQ(filesIn(dir / "new" / "out"), 0u);  // the probe is gone
}

TEST(AtomicFile, FileInPlaceOfTheFolderIsRefused) {
  const test::TempDir dir;
  const fs::path file = dir.write("out", "a file");
  std::string message = outputError([&] { requireWritableFolder(file, "--out folder"); });
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;
  EXPECT_NE(message.find("not a folder"), std::string::npos) << message;
  message = outputError([&] { requireWritableFolder("/dev/full", "--out folder"); });
  EXPECT_NE(message.find("/dev/full"), std::string::npos) << message;
  message = outputError([&] { requireWritableFolder(file / "below", "--out folder"); });
  EXPECT_NE(message.find("below"), std::string::npos) << message;
}

}  // namespace
}  // namespace desslam
