// fishcam fit's input: correspondences as CSV (a header-only reader, so its fuzz
// harness uses exactly this code).
#pragma once

#include <charconv>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "fishcam/core/error.hpp"
#include "fishcam/io/file_input.hpp"

namespace fishcam::cli {

// A CSV with a header naming its columns: "theta,rho" (radians, px), "theta_deg,rho",
// or "x,y,z,u,v" (a ray in the camera frame and the pixel it hits). '#' comments.
struct CorrespondenceFile {
  enum class Kind { theta_rho, ray_pixel } kind;
  bool degrees = false;
  std::vector<std::vector<double>> rows;
};

inline CorrespondenceFile read_csv(const std::string& path) {
  std::istringstream in(read_bounded_file(path, std::size_t(64) << 20, "a correspondence CSV file"));
  CorrespondenceFile file{};
  size_t columns = 0;
  std::string line;
  for (long number = 1; std::getline(in, line); ++number) {
    std::string compact;
    for (char c : line) {
      if (c != ' ' && c != '\t' && c != '\r') compact += c;
    }
    if (compact.empty() || compact[0] == '#') continue;
    if (columns == 0) {
      if (compact == "theta,rho" || compact == "theta_deg,rho") {
        file.kind = CorrespondenceFile::Kind::theta_rho, file.degrees = compact == "theta_deg,rho", columns = 2;
      } else if (compact == "x,y,z,u,v") {
        file.kind = CorrespondenceFile::Kind::ray_pixel, columns = 5;
      } else {
        throw Error(path + ":" + std::to_string(number) +
                    ": expected a header 'theta,rho', 'theta_deg,rho' or "
                    "'x,y,z,u,v', got " +
                    quoted_for_message(line));
      }
      continue;
    }
    std::vector<double> row;
    const char* p = compact.data();
    const char* end = p + compact.size();
    while (p <= end && row.size() <= columns) {
      double value;
      const auto [next, ec] = std::from_chars(p, end, value);
      if (ec != std::errc() || !std::isfinite(value) || (next != end && *next != ',')) {
        throw Error(path + ":" + std::to_string(number) + ": expected " + std::to_string(columns) +
                    " finite numbers separated by commas");
      }
      row.push_back(value);
      p = next + 1;
    }
    if (row.size() != columns) {
      throw Error(path + ":" + std::to_string(number) + ": expected " + std::to_string(columns) + " numbers, got " +
                  std::to_string(row.size()));
    }
    file.rows.push_back(std::move(row));
  }
  if (columns == 0) throw Error(path + ": empty (no header)");
  if (file.rows.empty()) throw Error(path + ": no data rows");
  return file;
}

}  // namespace fishcam::cli
