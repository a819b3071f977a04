// Reading an input file with its size bounded before anything is read: only regular
// files (a device such as /dev/zero would be read until memory runs out, a FIFO
// without a writer would block forever, a socket neither), opened without blocking,
// refused past a limit that the caller chooses for what it reads. Every reader of
// the library, the program and the Python package reads its files through this.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

namespace fishcam {

// The whole file at path, at most max_bytes. Throws Error naming the file: cannot
// open, is a directory, not a regular file, larger than the limit ("larger than
// 64 MiB, not a corners file" with what = "a corners file"), read error.
std::string read_bounded_file(const std::filesystem::path& path, std::size_t max_bytes,
                              std::string_view what = "an input file");

// Checks what read_bounded_file checks (regular file, size), without reading:
// for readers that hand the path to another library (image decoders).
void check_bounded_file(const std::filesystem::path& path, std::size_t max_bytes,
                        std::string_view what = "an input file");

// "64 MiB", "512 kB": a byte limit for messages.
std::string byte_size_for_message(std::size_t bytes);

}  // namespace fishcam
