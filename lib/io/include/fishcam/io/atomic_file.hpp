// Writing files so that nothing is ever half-written, lost or written through a
// link: each file goes to a temporary of its own beside it, created exclusively
// (never an existing file, never through a symlink), named
// NAME.HOST.PID.RANDOM.fishcam-tmp (an extension no reader takes), and is renamed
// into place only once all of it is on disk. A rename replaces a symlink or a hard
// link at the destination, never the file it points to. Runs in parallel into one
// folder never touch each other's temporaries.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace fishcam {

// Writes bytes to path. Refuses to replace an existing file unless overwrite (the
// refusal is atomic: a file that appears meanwhile is not replaced either).
// Throws Error naming the file and the cause ("no space left on device", ...);
// on failure the temporary is removed and an existing file is untouched.
void write_file_atomically(const std::filesystem::path& path, const std::string& bytes, bool overwrite);

// Several files committed together: all are checked (distinct, absent unless
// overwrite) and written to temporaries before any is renamed into place.
void write_files_atomically(const std::vector<std::pair<std::filesystem::path, std::string>>& files, bool overwrite);

// The temporary a process (process_id, on this host) names path's with token as
// its random part: PATH.HOST.PID.TOKEN.fishcam-tmp.
std::filesystem::path temporary_path(const std::filesystem::path& path, long process_id, std::uint64_t token);

// Whether name is one of write_file_atomically's temporaries.
bool is_temporary_name(const std::string& name);

// Removes the temporaries in folder (not below it) left by processes of this host
// that no longer run (a killed run); those of running processes, of other hosts
// and everything else stay. Returns how many were removed.
std::size_t remove_stale_temporaries(const std::filesystem::path& folder);

// Whether a and b name the same file or folder (symlinks resolved, hard links and
// bind mounts recognised), or the same path where neither exists yet.
bool is_same_file(const std::filesystem::path& a, const std::filesystem::path& b);

// Refuses (Error naming `what` and both paths) an output that is an input, lies
// inside an input folder, or, for an output folder, contains an input. Paths are
// compared as the files they resolve to: symlinks followed, hard links and bind
// mounts recognised as the same file.
void check_output_not_input(const std::filesystem::path& output, const std::vector<std::filesystem::path>& inputs,
                            bool output_is_folder);

}  // namespace fishcam
