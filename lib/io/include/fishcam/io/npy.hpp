// numpy .npy files (format version 1.0) of little-endian float32 arrays: what
// `fishcam map` writes and what mrcal's Python side hands back.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace fishcam {

struct NpyArray {
  std::vector<std::size_t> shape;
  std::vector<float> data;  // C order
};

// The file's bytes; name (the file) is for the error message.
std::string npy_bytes(const NpyArray& array, const std::string& name);
// Writes atomically; refuses to replace an existing file unless overwrite is true.
void write_npy(const std::filesystem::path& path, const NpyArray& array, bool overwrite = false);
// Reads '<f4' C-order arrays only; throws Error naming the file and the problem.
NpyArray read_npy(const std::filesystem::path& path);

}  // namespace fishcam
