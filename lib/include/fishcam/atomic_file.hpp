// Writing files so that nothing is ever half-written or lost: each file goes to a
// temporary beside it (NAME.fishcam-tmp, an extension no reader takes) and is
// renamed into place only once all of it is on disk.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace fishcam {

// Writes bytes to path. Refuses to replace an existing file unless overwrite.
// Throws Error naming the file and the cause ("no space left on device", ...);
// on failure the temporary is removed and an existing file is untouched.
void write_file_atomically(const std::filesystem::path& path, const std::string& bytes, bool overwrite);

// Several files committed together: all are checked (distinct, absent unless
// overwrite) and written to temporaries before any is renamed into place.
void write_files_atomically(const std::vector<std::pair<std::filesystem::path, std::string>>& files, bool overwrite);

// The temporary write_file_atomically uses for path (for cleaning up after a crash).
std::filesystem::path temporary_path(const std::filesystem::path& path);

}  // namespace fishcam
