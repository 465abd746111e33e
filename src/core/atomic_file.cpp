#include "core/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

#include "core/error.hpp"

namespace desslam {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kTempPrefix = ".desslam-tmp-";

[[noreturn]] void fail(std::string_view what, const fs::path& path, const std::string& reason) {
  throw OutputError("cannot write " + std::string(what) + " " + path.string() + ": " + reason);
}

std::string errnoText(int error) { return error != 0 ? std::strerror(error) : "unknown error"; }

// Closes fd when it goes out of scope unless released (error paths).
struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
  // Checked close: the fd is gone either way.
  int close() {
    const int result = ::close(fd);
    fd = -1;
    return result;
  }
};

void writeAll(int fd, std::string_view bytes, std::string_view what, const fs::path& path) {
  const char* data = bytes.data();
  size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, data, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(what, path, errnoText(errno));
    }
    if (n == 0) fail(what, path, "write returned 0 bytes");
    data += n;
    left -= static_cast<size_t>(n);
  }
}

// fsync of the folder, so the rename itself survives a crash (best effort: some file systems
// refuse fsync on folders).
void syncFolder(const fs::path& path) {
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// fsync + close of a file the caller has written; then rename onto path. Removes tmp on failure.
void syncAndRename(const fs::path& tmp, const fs::path& path, std::string_view what, Fd& file) {
  if (::fsync(file.fd) != 0) {
    const int error = errno;
    fail(what, path, errnoText(error));
  }
  if (file.close() != 0) {
    const int error = errno;
    fail(what, path, errnoText(error));
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    fail(what, path, "cannot rename " + tmp.filename().string() + " onto it: " + errnoText(error));
  }
  syncFolder(path);
}

// Removes tmp unless dismissed (the rename consumed it).
struct TempGuard {
  fs::path path;
  bool armed = true;
  ~TempGuard() {
    if (armed) ::unlink(path.c_str());
  }
};

}  // namespace

fs::path atomicTempPath(const fs::path& target) {
  return target.parent_path() /
         (std::string(kTempPrefix) + std::to_string(::getpid()) + "-" + target.filename().string());
}

bool isAtomicTempName(const std::string& file_name) { return file_name.rfind(kTempPrefix, 0) == 0; }

void writeFileAtomically(const fs::path& path, std::string_view bytes, std::string_view what) {
  const fs::path tmp = atomicTempPath(path);
  Fd file;
  file.fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (file.fd < 0) {
    const int error = errno;
    fail(what, path, errnoText(error));
  }
  TempGuard guard{tmp};
  writeAll(file.fd, bytes, what, path);
  syncAndRename(tmp, path, what, file);
  guard.armed = false;
}

void writeFileAtomicallyVia(const fs::path& path, std::string_view what,
                            const std::function<bool(const fs::path& tmp)>& write) {
  const fs::path tmp = atomicTempPath(path);
  TempGuard guard{tmp};
  errno = 0;
  if (!write(tmp)) {
    const int error = errno;
    fail(what, path, error != 0 ? errnoText(error) : "the writer reported a failure (check free disk space)");
  }
  Fd file;
  file.fd = ::open(tmp.c_str(), O_RDWR | O_CLOEXEC);
  if (file.fd < 0) {
    const int error = errno;
    fail(what, path, "the writer left no file: " + errnoText(error));
  }
  syncAndRename(tmp, path, what, file);
  guard.armed = false;
}

void requireWritableFolder(const fs::path& dir, std::string_view what) {
  const auto refuse = [&](const std::string& reason) {
    throw OutputError(std::string(what) + " " + dir.string() + " cannot be written: " + reason);
  };
  std::error_code ec;
  const fs::file_status status = fs::status(dir, ec);
  if (fs::exists(status) && !fs::is_directory(status)) refuse("it exists and is not a folder (choose another)");
  fs::create_directories(dir, ec);
  if (ec) refuse(ec.message());
  const fs::path probe = dir / (std::string(kTempPrefix) + std::to_string(::getpid()) + "-write-probe");
  Fd file;
  file.fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (file.fd < 0) refuse(errnoText(errno));
  TempGuard guard{probe};
  const char byte = '\n';
  ssize_t n;
  do {
    n = ::write(file.fd, &byte, 1);
  } while (n < 0 && errno == EINTR);
  if (n != 1) refuse(errnoText(n < 0 ? errno : 0));
  if (::fsync(file.fd) != 0) refuse(errnoText(errno));
  if (file.close() != 0) refuse(errnoText(errno));
}

}  // namespace desslam
