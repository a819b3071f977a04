#include "fishcam/augment/charuco.hpp"

#include <opencv2/aruco.hpp>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include "fishcam/core/error.hpp"
#include "target_text.hpp"

namespace fishcam {
namespace {

// OpenCV's predefined dictionaries, by the names --target takes.
constexpr std::array<std::pair<std::string_view, cv::aruco::PREDEFINED_DICTIONARY_NAME>, 21> kDictionaries{{
    {"4X4_50", cv::aruco::DICT_4X4_50},
    {"4X4_100", cv::aruco::DICT_4X4_100},
    {"4X4_250", cv::aruco::DICT_4X4_250},
    {"4X4_1000", cv::aruco::DICT_4X4_1000},
    {"5X5_50", cv::aruco::DICT_5X5_50},
    {"5X5_100", cv::aruco::DICT_5X5_100},
    {"5X5_250", cv::aruco::DICT_5X5_250},
    {"5X5_1000", cv::aruco::DICT_5X5_1000},
    {"6X6_50", cv::aruco::DICT_6X6_50},
    {"6X6_100", cv::aruco::DICT_6X6_100},
    {"6X6_250", cv::aruco::DICT_6X6_250},
    {"6X6_1000", cv::aruco::DICT_6X6_1000},
    {"7X7_50", cv::aruco::DICT_7X7_50},
    {"7X7_100", cv::aruco::DICT_7X7_100},
    {"7X7_250", cv::aruco::DICT_7X7_250},
    {"7X7_1000", cv::aruco::DICT_7X7_1000},
    {"ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
    {"APRILTAG_16h5", cv::aruco::DICT_APRILTAG_16h5},
    {"APRILTAG_25h9", cv::aruco::DICT_APRILTAG_25h9},
    {"APRILTAG_36h10", cv::aruco::DICT_APRILTAG_36h10},
    {"APRILTAG_36h11", cv::aruco::DICT_APRILTAG_36h11},
}};

cv::Ptr<cv::aruco::Dictionary> dictionary_of(const std::string& name) {
  for (const auto& [known, id] : kDictionaries) {
    if (known == name) return cv::aruco::getPredefinedDictionary(id);
  }
  std::string names;
  for (const auto& [known, id] : kDictionaries) names += (names.empty() ? "" : ", ") + std::string(known);
  throw Error("charuco: unknown dictionary '" + text_for_message(name) + "' (one of " + names + ")");
}

cv::Ptr<cv::aruco::CharucoBoard> board_of(const CharucoSpec& spec) {
  return cv::aruco::CharucoBoard::create(spec.cols, spec.rows, float(spec.square), float(spec.marker),
                                         dictionary_of(spec.dictionary));
}

}  // namespace

std::vector<std::string> charuco_dictionaries() {
  std::vector<std::string> names;
  for (const auto& [name, id] : kDictionaries) names.emplace_back(name);
  return names;
}

CharucoSpec parse_charuco(std::string_view text) {
  const std::string form =
      "expected charuco:COLSxROWS:SQUARE:MARKER[:DICTIONARY] (squares, their side and the "
      "markers' side, e.g. charuco:8x6:0.04:0.03)";
  const std::vector<std::string_view> fields = detail::target_fields(text);
  if (fields.size() < 4 || fields.size() > 5 || fields[0] != "charuco") {
    throw Error("--target '" + text_for_message(text) + "': " + form);
  }
  CharucoSpec spec;
  if (!detail::parse_size(fields[1], &spec.cols, &spec.rows) || !detail::parse_number(fields[2], &spec.square) ||
      !detail::parse_number(fields[3], &spec.marker)) {
    throw Error("--target '" + text_for_message(text) + "': " + form);
  }
  if (fields.size() == 5) spec.dictionary = std::string(fields[4]);
  check_charuco(spec);
  return spec;
}

void check_charuco(const CharucoSpec& spec) {
  if (spec.cols < 3 || spec.rows < 3 || spec.cols > 1000 || spec.rows > 1000) {
    throw Error("charuco: needs 3 to 1000 squares per side, got " + std::to_string(spec.cols) + "x" +
                std::to_string(spec.rows));
  }
  if (!(spec.square > 0 && std::isfinite(spec.square))) {
    throw Error("charuco: the squares' side must be a finite number > 0, got " + number_for_message(spec.square));
  }
  check_board(spec.board());
  if (!(spec.marker > 0 && spec.marker < spec.square)) {
    throw Error("charuco: the markers' side must lie between 0 and the squares' (" + number_for_message(spec.square) +
                "), got " + number_for_message(spec.marker));
  }
  const int markers = spec.cols * spec.rows / 2;  // one in every white square
  const int codes = dictionary_of(spec.dictionary)->bytesList.rows;
  if (markers > codes) {
    throw Error("charuco: a " + std::to_string(spec.cols) + "x" + std::to_string(spec.rows) + " board needs " +
                std::to_string(markers) + " markers; the dictionary " + spec.dictionary + " has " +
                std::to_string(codes));
  }
}

std::optional<BoardObservation> detect_charuco(const cv::Mat& gray, const CharucoSpec& spec) {
  check_charuco(spec);
  if (gray.type() != CV_8UC1) throw Error("charuco detection takes an 8-bit grayscale image");
  const cv::Ptr<cv::aruco::CharucoBoard> board = board_of(spec);
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(gray, board->dictionary, marker_corners, marker_ids);
  if (marker_ids.empty()) return std::nullopt;
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, board, corners, ids);
  std::vector<std::pair<int, Eigen::Vector2d>> found;
  for (size_t k = 0; k < ids.size(); ++k) {
    if (ids[k] >= 0 && ids[k] < spec.board().corners())
      found.emplace_back(ids[k], Eigen::Vector2d(corners[k].x, corners[k].y));
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  BoardObservation out;
  std::set<int> columns, rows;
  for (const auto& [id, corner] : found) {
    if (!out.ids.empty() && out.ids.back() == id) continue;
    out.ids.push_back(id), out.corners.push_back(corner);
    columns.insert(id % spec.board().cols), rows.insert(id / spec.board().cols);
  }
  if (out.corners.size() < 6 || columns.size() < 2 || rows.size() < 2) return std::nullopt;
  // OpenCV 4.6's interpolation returns its cornerSubPix result shifted by +0.5 px in x
  // and y (opencv/opencv#25539: fixed in later releases): each corner refined again
  // from there, in cornerSubPix's own convention (pixel centres at integers), with a
  // window that keeps clear of the markers (whose edges would pull the corner): 80 %
  // of the square's margin around its marker, scaled by the distance to the nearest
  // other corner, at most 45 % of it (as detect_chessboard's) and 2 to 5 px.
  const double margin = (spec.square - spec.marker) / (2 * spec.square);
  const cv::TermCriteria until(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 1e-3);
  for (size_t k = 0; k < out.corners.size(); ++k) {
    double nearest = std::numeric_limits<double>::infinity();
    for (size_t other = 0; other < out.corners.size(); ++other) {
      if (other != k) nearest = std::min(nearest, (out.corners[other] - out.corners[k]).norm());
    }
    const int half = std::clamp(int(std::min(0.45, 0.8 * margin) * nearest), 2, 5);
    std::vector<cv::Point2f> one = {cv::Point2f(float(out.corners[k].x()), float(out.corners[k].y()))};
    cv::cornerSubPix(gray, one, {half, half}, {-1, -1}, until);
    out.corners[k] = {one[0].x, one[0].y};
  }
  if (int(out.corners.size()) == spec.board().corners()) out.ids.clear();  // the whole board
  return out;
}

CharucoTexture::CharucoTexture(const CharucoSpec& spec, int pixels_per_square)
    : square_(spec.square), pixels_per_square_(pixels_per_square) {
  check_charuco(spec);
  if (pixels_per_square < 8 || pixels_per_square > 512) {
    throw Error("charuco: pixels per square must lie within [8, 512], got " + std::to_string(pixels_per_square));
  }
  board_of(spec)->draw(cv::Size(spec.cols * pixels_per_square, spec.rows * pixels_per_square), image_, 0, 1);
}

double CharucoTexture::operator()(double x, double y) const {
  // Inner corner 0 lies one square in from the drawing's top left corner.
  const double u = (x / square_ + 1) * pixels_per_square_, v = (y / square_ + 1) * pixels_per_square_;
  if (u >= 0 && v >= 0 && u < image_.cols && v < image_.rows) return image_.at<std::uint8_t>(int(v), int(u));
  const double margin = pixels_per_square_;
  if (u >= -margin && v >= -margin && u < image_.cols + margin && v < image_.rows + margin) return 255;
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace fishcam
