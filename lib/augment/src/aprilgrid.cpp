#include "fishcam/augment/aprilgrid.hpp"

#include <apriltag.h>
#include <tag36h11.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <utility>

#include "fishcam/core/error.hpp"
#include "target_text.hpp"

namespace fishcam {
namespace {

// Kalibr's tags: 6 x 6 data bits inside a black border two bits wide (libapriltag's
// own 36h11 has a one-bit border), no white border of their own (the gaps are white).
constexpr int kBorderBits = 2, kDataBits = 6, kTagBits = kDataBits + 2 * kBorderBits;
// libapriltag's corners p[0..3] of a tag seen upright are its bottom left, bottom
// right, top right and top left corners: (column, row) of each among the tag's two
// columns and two rows of board corners (rows counted down the board).
constexpr std::array<std::pair<int, int>, 4> kCornerOfDetection{{{0, 1}, {1, 1}, {1, 0}, {0, 0}}};

// libapriltag's tag36h11 with Kalibr's border: the same codes, the family two bits
// wider at its border (its bits one further in). Owns the families and the detector.
class KalibrDetector {
 public:
  KalibrDetector() : standard_(tag36h11_create()), family_(*standard_) {
    bit_x_.assign(standard_->bit_x, standard_->bit_x + standard_->nbits);
    bit_y_.assign(standard_->bit_y, standard_->bit_y + standard_->nbits);
    for (auto& b : bit_x_) ++b;
    for (auto& b : bit_y_) ++b;
    family_.bit_x = bit_x_.data(), family_.bit_y = bit_y_.data();
    family_.width_at_border = kTagBits, family_.total_width = kTagBits + 2;
    family_.impl = nullptr;
    detector_ = apriltag_detector_create();
    if (!detector_) {
      tag36h11_destroy(standard_);
      throw Error("aprilgrid: libapriltag could not create a detector");
    }
    detector_->nthreads = 1;
    detector_->quad_decimate = 1;  // full resolution: small tags near a fisheye's rim
    detector_->refine_edges = true;
    // Closing and opening the thresholded image (deglitch) keeps small tags' borders
    // whole: it found 93 % of the visible corners of fisheye renders, 52 % without.
    detector_->qtp.deglitch = true;
    // One corrected bit, as detect() keeps: two would build a 36 MB decoding table.
    apriltag_detector_add_family_bits(detector_, &family_, 1);
  }
  KalibrDetector(const KalibrDetector&) = delete;
  KalibrDetector& operator=(const KalibrDetector&) = delete;
  ~KalibrDetector() {
    apriltag_detector_destroy(detector_);  // frees the family's decoding table
    tag36h11_destroy(standard_);
  }

  // (id, corners p[0..3]) of each tag found in `gray` with at most one bit corrected.
  std::vector<std::pair<int, std::array<Eigen::Vector2d, 4>>> detect(const cv::Mat& gray) const {
    image_u8_t image{gray.cols, gray.rows, int(gray.step[0]), gray.data};
    zarray_t* found = apriltag_detector_detect(detector_, &image);
    std::vector<std::pair<int, std::array<Eigen::Vector2d, 4>>> out;
    for (int k = 0; k < zarray_size(found); ++k) {
      apriltag_detection_t* detection = nullptr;
      zarray_get(found, k, &detection);
      if (detection->hamming > 1) continue;
      std::array<Eigen::Vector2d, 4> corners;
      for (int c = 0; c < 4; ++c) corners[size_t(c)] = {detection->p[c][0], detection->p[c][1]};
      out.emplace_back(detection->id, corners);
    }
    apriltag_detections_destroy(found);
    return out;
  }

  const apriltag_family_t& standard() const { return *standard_; }

 private:
  apriltag_family_t* standard_;
  apriltag_family_t family_;
  std::vector<uint32_t> bit_x_, bit_y_;
  apriltag_detector_t* detector_ = nullptr;
};

// The board corner (column, row) of corner `c` (kCornerOfDetection) of tag `id`.
std::pair<int, int> corner_of(const AprilGridSpec& spec, int id, int c) {
  const int column = id % spec.cols, row_from_top = spec.rows - 1 - id / spec.cols;
  const auto [dx, dy] = kCornerOfDetection[size_t(c)];
  return {2 * column + dx, 2 * row_from_top + dy};
}

}  // namespace

AprilGridSpec parse_aprilgrid(std::string_view text) {
  const std::string form =
      "expected aprilgrid:COLSxROWS:SIZE:SPACING (tags, their side and the gap between them as a fraction of the "
      "side, as Kalibr's tagCols, tagRows, tagSize, tagSpacing; e.g. aprilgrid:6x6:0.088:0.3)";
  const std::vector<std::string_view> fields = detail::target_fields(text);
  AprilGridSpec spec;
  if (fields.size() != 4 || fields[0] != "aprilgrid" || !detail::parse_size(fields[1], &spec.cols, &spec.rows) ||
      !detail::parse_number(fields[2], &spec.size) || !detail::parse_number(fields[3], &spec.spacing)) {
    throw Error("--target '" + text_for_message(text) + "': " + form);
  }
  check_aprilgrid(spec);
  return spec;
}

void check_aprilgrid(const AprilGridSpec& spec) {
  if (spec.cols < 1 || spec.rows < 1 || spec.cols > 100 || spec.rows > 100 || spec.cols * spec.rows < 2) {
    throw Error("aprilgrid: needs 1 to 100 tags per side and 2 tags or more (a view needs corners of 2), got " +
                std::to_string(spec.cols) + "x" + std::to_string(spec.rows));
  }
  constexpr int kCodes = 587;  // tag36h11's
  if (spec.cols * spec.rows > kCodes) {
    throw Error("aprilgrid: " + std::to_string(spec.cols * spec.rows) + " tags; the 36h11 family has " +
                std::to_string(kCodes));
  }
  if (!(spec.size > 0 && std::isfinite(spec.size))) {
    throw Error("aprilgrid: the tags' side must be a finite number > 0, got " + number_for_message(spec.size));
  }
  if (!(spec.spacing > 0 && spec.spacing <= 1)) {
    throw Error("aprilgrid: the spacing (the gap between tags over their side) must lie within (0, 1], got " +
                number_for_message(spec.spacing));
  }
  check_board(spec.board());
}

std::optional<BoardObservation> detect_aprilgrid(const cv::Mat& gray, const AprilGridSpec& spec) {
  check_aprilgrid(spec);
  if (gray.type() != CV_8UC1) throw Error("aprilgrid detection takes an 8-bit grayscale image");
  const BoardSpec board = spec.board();
  // The gap squares touch the tags at their corners, which joins every tag's border
  // into one black region that libapriltag cannot split into quads: the image is
  // doubled (small tags' bits stay a few pixels wide) and brightened by one pixel of
  // the doubled image, which parts them.
  cv::Mat brightened;
  cv::resize(gray, brightened, cv::Size(), 2, 2, cv::INTER_LINEAR);
  cv::dilate(brightened, brightened, cv::Mat());
  const KalibrDetector detector;
  std::vector<std::pair<int, Eigen::Vector2d>> found;
  for (auto [id, corners] : detector.detect(brightened)) {
    // libapriltag's pixel centres lie at +0.5, OpenCV's at integers; the doubled
    // image's pixel j covers the original's (j + 0.5) / 2 - 0.5.
    for (auto& p : corners) p = p / 2 - Eigen::Vector2d::Constant(0.5);
    if (id < 0 || id >= spec.cols * spec.rows) continue;  // another tag in view
    // Each corner refined on the image itself, with a window inside the X junction:
    // 15 % of the tag's side (its border is 20 %) and half the gap (the next tag's
    // corner lies a gap away), 2 to 8 px.
    const double side = ((corners[0] - corners[1]).norm() + (corners[1] - corners[2]).norm() +
                         (corners[2] - corners[3]).norm() + (corners[3] - corners[0]).norm()) /
                        4;
    const int half = std::clamp(int(std::min(0.15, 0.5 * spec.spacing) * side), 2, 8);
    std::vector<cv::Point2f> refined;
    for (const auto& p : corners) refined.emplace_back(float(p.x()), float(p.y()));
    cv::cornerSubPix(gray, refined, {half, half}, {-1, -1},
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 1e-3));
    for (int c = 0; c < 4; ++c) {
      const Eigen::Vector2d p(refined[size_t(c)].x, refined[size_t(c)].y);
      // A corner that moved further than the brightening explains left its junction;
      // one whose window the image's edge cuts was refined on part of it.
      if ((p - corners[size_t(c)]).norm() > std::max(2.5, 0.05 * side)) continue;
      if (!(p.x() >= half + 1 && p.y() >= half + 1 && p.x() <= gray.cols - half - 2 && p.y() <= gray.rows - half - 2)) {
        continue;
      }
      const auto [column, row] = corner_of(spec, id, c);
      found.emplace_back(row * board.cols + column, p);
    }
  }
  std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  BoardObservation out;
  std::set<int> columns, rows;
  for (const auto& [id, corner] : found) {
    if (!out.ids.empty() && out.ids.back() == id) continue;  // a tag seen twice: the first
    out.ids.push_back(id), out.corners.push_back(corner);
    columns.insert(id % board.cols), rows.insert(id / board.cols);
  }
  if (out.corners.size() < 6 || columns.size() < 2 || rows.size() < 2) return std::nullopt;
  if (int(out.corners.size()) == board.corners()) out.ids.clear();  // the whole board
  return out;
}

AprilGridTexture::AprilGridTexture(const AprilGridSpec& spec) : spec_(spec) {
  check_aprilgrid(spec);
  apriltag_family_t* family = tag36h11_create();
  // libapriltag draws a tag upright with a one-bit black border inside a one-bit white
  // one: its data bits are the 6 x 6 pixels two in from the edge.
  for (int id = 0; id < spec.cols * spec.rows; ++id) {
    image_u8_t* tag = apriltag_to_image(family, uint32_t(id));
    std::vector<bool> bits;
    for (int r = 0; r < kDataBits; ++r) {
      for (int c = 0; c < kDataBits; ++c) bits.push_back(tag->buf[(r + 2) * tag->stride + c + 2] < 128);
    }
    image_u8_destroy(tag);
    black_bits_.push_back(std::move(bits));
  }
  tag36h11_destroy(family);
}

double AprilGridTexture::operator()(double x, double y) const {
  const double size = spec_.size, pitch = size * (1 + spec_.spacing);
  constexpr double kWhite = 255, kBlack = 0;
  if (!(x >= -pitch && y >= -pitch && x < spec_.cols * pitch + size && y < spec_.rows * pitch + size)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  // The tag column and row (from the top) of the cell holding (x, y): a tag of side
  // `size`, then the gap to the next.
  const int column = int(std::floor(x / pitch)), row = int(std::floor(y / pitch));
  const double u = x - column * pitch, v = y - row * pitch;
  const bool tag_column = column >= 0 && column < spec_.cols, tag_row = row >= 0 && row < spec_.rows;
  if (u < size && v < size) {
    if (!tag_column || !tag_row) return kWhite;
    const int bit_x = int(u / size * kTagBits), bit_y = int(v / size * kTagBits);
    if (bit_x < kBorderBits || bit_y < kBorderBits || bit_x >= kTagBits - kBorderBits ||
        bit_y >= kTagBits - kBorderBits) {
      return kBlack;
    }
    const int id = (spec_.rows - 1 - row) * spec_.cols + column;
    return black_bits_[size_t(id)][size_t((bit_y - kBorderBits) * kDataBits + bit_x - kBorderBits)] ? kBlack : kWhite;
  }
  // A square in the gaps where they cross, beside the corner of any tag.
  if (u >= size && v >= size) {
    const bool beside_a_tag = column >= -1 && column < spec_.cols && row >= -1 && row < spec_.rows;
    return beside_a_tag ? kBlack : kWhite;
  }
  return kWhite;
}

}  // namespace fishcam
