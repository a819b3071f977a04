#include "fishcam/io/npy.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <regex>
#include <sstream>
#include <string>

#include "fishcam/core/error.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/file_input.hpp"

namespace fishcam {

static_assert(std::endian::native == std::endian::little, "the .npy code writes native little-endian floats");

std::string npy_bytes(const NpyArray& array, const std::string& name) {
  size_t count = 1;
  std::string shape = "(";
  for (size_t d : array.shape) {
    count *= d;
    shape += std::to_string(d) + ", ";
  }
  if (array.shape.size() > 1) shape.erase(shape.size() - 1);  // "(3, 4)" and "(3,)"
  shape += ")";
  if (count != array.data.size()) throw Error(name + ": shape does not match the data size");
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': " + shape + ", }";
  // magic (6) + version (2) + header length (2) + header, padded with spaces and
  // ended by a newline to a multiple of 64 bytes.
  const size_t total = (10 + header.size() + 1 + 63) / 64 * 64;
  header.append(total - 10 - header.size() - 1, ' ');
  header += '\n';
  const unsigned char preamble[10] = {0x93,
                                      'N',
                                      'U',
                                      'M',
                                      'P',
                                      'Y',
                                      1,
                                      0,
                                      static_cast<unsigned char>(header.size() & 0xff),
                                      static_cast<unsigned char>(header.size() >> 8)};
  std::string bytes(reinterpret_cast<const char*>(preamble), sizeof preamble);
  bytes += header;
  bytes.append(reinterpret_cast<const char*>(array.data.data()), count * sizeof(float));
  return bytes;
}

void write_npy(const std::filesystem::path& path, const NpyArray& array, bool overwrite) {
  write_file_atomically(path, npy_bytes(array, path.string()), overwrite);
}

NpyArray read_npy(const std::filesystem::path& path) {
  // The largest array fishcam writes or reads is a map of an 8192 x 8192 image.
  std::istringstream in(read_bounded_file(path, std::size_t(1) << 30, "a .npy file"), std::ios::binary);
  unsigned char preamble[10];
  if (!in.read(reinterpret_cast<char*>(preamble), 10) || std::memcmp(preamble, "\x93NUMPY", 6) != 0) {
    throw Error(path.string() + ": not a .npy file");
  }
  if (preamble[6] != 1) throw Error(path.string() + ": only .npy format version 1.0 is read");
  std::string header(size_t(preamble[8]) | (size_t(preamble[9]) << 8), '\0');
  if (!in.read(header.data(), static_cast<std::streamsize>(header.size())))
    throw Error(path.string() + ": truncated header");
  if (header.find("'descr': '<f4'") == std::string::npos)
    throw Error(path.string() + ": descr: expected '<f4' (float32)");
  if (header.find("'fortran_order': False") == std::string::npos)
    throw Error(path.string() + ": fortran_order: expected False");
  std::smatch match;
  if (!std::regex_search(header, match, std::regex(R"('shape': \(([0-9, ]*)\))")))
    throw Error(path.string() + ": shape: missing");
  NpyArray array;
  // The element count is checked against the file's size before anything is
  // allocated (a 128-byte header must not make us zero-fill gigabytes).
  const auto file_size = in.str().size();
  const size_t data_bytes = size_t(file_size) - std::min<size_t>(size_t(file_size), 10 + header.size());
  size_t count = 1;
  const std::string dims = match[1];
  const std::regex number("[0-9]+");
  for (std::sregex_iterator it(dims.begin(), dims.end(), number), end; it != end; ++it) {
    const std::string digits = it->str();
    if (digits.size() > 12) throw Error(path.string() + ": shape: dimension too large");
    const size_t dim = std::stoull(digits);
    array.shape.push_back(dim);
    if (dim != 0 && count > data_bytes / sizeof(float) / dim) {
      throw Error(path.string() + ": shape: more elements than the file holds (truncated or corrupt)");
    }
    count *= dim;
  }
  if (count * sizeof(float) != data_bytes) {
    throw Error(path.string() + ": shape: " + std::to_string(count) + " elements, but the file holds " +
                std::to_string(data_bytes) + " data bytes");
  }
  array.data.resize(count);
  if (!in.read(reinterpret_cast<char*>(array.data.data()), static_cast<std::streamsize>(count * sizeof(float)))) {
    throw Error(path.string() + ": truncated data");
  }
  return array;
}

}  // namespace fishcam
