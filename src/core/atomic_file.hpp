// Output files that are either complete or absent: every writer of the project writes into a
// temporary file beside its target (same folder, so the rename is atomic), checks every write and
// the close, fsyncs it, then renames it onto the target. A failure (no space, no permission, file
// too large) throws OutputError naming the file and the system's reason, removes the temporary
// file and leaves the target as it was (an earlier version stays whole).
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

namespace desslam {

// The temporary file beside `target`: ".desslam-tmp-<pid>-<file name>" (it keeps the target's
// extension, which writers that choose the format by it need).
std::filesystem::path atomicTempPath(const std::filesystem::path& target);
// Whether a file name is such a temporary file (a leftover of a killed process).
bool isAtomicTempName(const std::string& file_name);

// Writes `bytes` to `path` atomically. `what` names the kind of file in messages ("report",
// "trajectory file"). The folder must exist. Throws OutputError.
void writeFileAtomically(const std::filesystem::path& path, std::string_view bytes, std::string_view what = "file");

// The same for writers that only take a path (Open3D, OctoMap, OpenCV): `write(tmp)` writes the
// whole file at tmp and returns false when it failed; then fsync and rename as above. errno, when
// the writer leaves one, is the reason given. Throws OutputError (and lets write's own exceptions
// through after removing tmp).
void writeFileAtomicallyVia(const std::filesystem::path& path, std::string_view what,
                            const std::function<bool(const std::filesystem::path& tmp)>& write);

// Creates `dir` if needed, then writes, fsyncs and removes a probe file in it, so that a run
// learns before its first frame that its outputs cannot be written. Throws OutputError naming the
// folder and the reason ("Not a directory", "No space left on device", ...). `what` names the
// folder in messages (e.g. "--out folder").
void requireWritableFolder(const std::filesystem::path& dir, std::string_view what = "output folder");

}  // namespace desslam
