#include "fishcam/io/corners.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include "fishcam/core/error.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/file_input.hpp"

namespace fishcam {

std::vector<BoardObservation> read_corners(const std::filesystem::path& path, const BoardSpec& board) {
  // A corners file holds a line per corner: 64 MiB is hundreds of thousands of photos.
  std::istringstream in(read_bounded_file(path, std::size_t(64) << 20, "a corners file"));
  std::vector<BoardObservation> out;
  std::map<std::string, long> seen;
  std::string line;
  bool empty_board = false;
  auto close_image = [&](long number) {
    if (out.empty()) return;
    const auto& last = out.back();
    if (!empty_board && int(last.corners.size()) != board.corners()) {
      throw Error(path.string() + ":" + std::to_string(number) + ": image " + last.filename + ": expected " +
                  std::to_string(board.corners()) + " corners (" + std::to_string(board.cols) + "x" +
                  std::to_string(board.rows) + "), got " + std::to_string(last.corners.size()));
    }
  };
  long number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string filename, x, y, level, extra;
    if (!(fields >> filename >> x >> y >> level) || (fields >> extra)) {
      throw Error(path.string() + ":" + std::to_string(number) + ": expected 'filename x y level'");
    }
    if (out.empty() || out.back().filename != filename) {
      close_image(number - 1);
      if (seen.count(filename)) {
        throw Error(path.string() + ":" + std::to_string(number) + ": image " + filename +
                    " appears twice (its rows must be together)");
      }
      seen[filename] = number;
      out.push_back({filename, {}});
      empty_board = x == "-";
      if (empty_board) continue;
    } else if (empty_board || x == "-") {
      throw Error(path.string() + ":" + std::to_string(number) + ": image " + filename +
                  ": '- - -' (no board) must be the image's only row");
    }
    char* end_x = nullptr;
    char* end_y = nullptr;
    const double u = std::strtod(x.c_str(), &end_x), v = std::strtod(y.c_str(), &end_y);
    if (*end_x || *end_y || !std::isfinite(u) || !std::isfinite(v)) {
      throw Error(path.string() + ":" + std::to_string(number) + ": x and y must be finite numbers");
    }
    out.back().corners.emplace_back(u, v);
  }
  close_image(number);
  if (out.empty()) throw Error(path.string() + ": no corners");
  return out;
}

std::string format_corners(const std::vector<BoardObservation>& observations) {
  std::string out = "# filename x y level\n";
  char buffer[128];
  for (const auto& o : observations) {
    if (o.corners.empty()) out += o.filename + " - - -\n";
    for (const auto& c : o.corners) {
      if (!c.allFinite()) throw Error("corners: image " + o.filename + ": corners must be finite");
      std::snprintf(buffer, sizeof buffer, " %.17g %.17g 0\n", c.x(), c.y());
      out += o.filename + buffer;
    }
  }
  return out;
}

void write_corners(const std::filesystem::path& path, const std::vector<BoardObservation>& observations,
                   bool overwrite) {
  write_file_atomically(path, format_corners(observations), overwrite);
}

}  // namespace fishcam
