#include "fishcam/io/corners.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
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
  // The current image's rows: a corner, or nullopt for a row mrcal's way marks unused.
  std::vector<std::optional<Eigen::Vector2d>> rows;
  auto close_image = [&](long number) {
    if (out.empty()) return;
    BoardObservation& last = out.back();
    if (rows.size() == 1 && !rows[0]) return;  // "- - -": no board
    if (int(rows.size()) != board.corners()) {
      throw Error(path.string() + ":" + std::to_string(number) + ": image " + last.filename + ": expected " +
                  std::to_string(board.corners()) + " corners (" + std::to_string(board.cols) + "x" +
                  std::to_string(board.rows) + "), got " + std::to_string(rows.size()));
    }
    const bool whole = std::all_of(rows.begin(), rows.end(), [](const auto& r) { return r.has_value(); });
    for (size_t k = 0; k < rows.size(); ++k) {
      if (!rows[k]) continue;
      last.corners.push_back(*rows[k]);
      if (!whole) last.ids.push_back(int(k));
    }
  };
  long number = 0;
  std::string line;
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
      out.push_back({filename, {}, {}});
      rows.clear();
    }
    if (level == "-") {  // mrcal's mark for a corner not to use (x and y may be '-' too)
      rows.emplace_back(std::nullopt);
      continue;
    }
    char* end_x = nullptr;
    char* end_y = nullptr;
    const double u = std::strtod(x.c_str(), &end_x), v = std::strtod(y.c_str(), &end_y);
    if (*end_x || *end_y || !std::isfinite(u) || !std::isfinite(v)) {
      throw Error(path.string() + ":" + std::to_string(number) +
                  ": x and y must be finite numbers (a corner not observed has level '-')");
    }
    rows.emplace_back(Eigen::Vector2d(u, v));
  }
  close_image(number);
  if (out.empty()) throw Error(path.string() + ": no corners");
  return out;
}

std::string format_corners(const std::vector<BoardObservation>& observations, const BoardSpec& board) {
  std::string out = "# filename x y level\n";
  char buffer[128];
  for (const auto& o : observations) {
    check_observation(board, o);
    if (o.corners.empty()) out += o.filename + " - - -\n";
    size_t k = 0;  // the next of o's corners
    for (int id = 0; id < (o.corners.empty() ? 0 : board.corners()); ++id) {
      if (k == o.corners.size() || o.id(k) != id) {
        out += o.filename + " - - -\n";
        continue;
      }
      const Eigen::Vector2d& c = o.corners[k++];
      if (!c.allFinite()) throw Error("corners: image " + o.filename + ": corners must be finite");
      std::snprintf(buffer, sizeof buffer, " %.17g %.17g 0\n", c.x(), c.y());
      out += o.filename + buffer;
    }
  }
  return out;
}

void write_corners(const std::filesystem::path& path, const std::vector<BoardObservation>& observations,
                   const BoardSpec& board, bool overwrite) {
  write_file_atomically(path, format_corners(observations, board), overwrite);
}

}  // namespace fishcam
