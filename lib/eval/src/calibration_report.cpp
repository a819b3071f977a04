#include "fishcam/eval/calibration_report.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <numbers>
#include <set>

#include "fishcam/core/error.hpp"
#include "fishcam/core/model_registry.hpp"
#include "fishcam/io/png_image.hpp"
#include "report_figures.hpp"

namespace fishcam {

using detail::draw_arrow;
using detail::draw_text;
using detail::fixed_text;
using detail::kBlue;
using detail::kInk;
using detail::kRed;

namespace {
// The observations as the solve numbered them: a rig's renumbered images reversed.
std::vector<BoardObservation> as_solved(const CalibrationResult& result,
                                        const std::vector<BoardObservation>& observations, const BoardSpec& board) {
  std::vector<BoardObservation> out = observations;
  const std::set<std::string> renumbered(result.renumbered_images.begin(), result.renumbered_images.end());
  for (auto& o : out) {
    if (renumbered.count(o.filename)) o = renumbered_from_other_end(board, std::move(o));
  }
  return out;
}
}  // namespace

std::vector<CornerFit> corner_fits(const CalibrationResult& result, const std::vector<BoardObservation>& observations,
                                   const BoardSpec& board) {
  const std::vector<BoardObservation> solved = as_solved(result, observations, board);
  const std::set<std::string> renumbered(result.renumbered_images.begin(), result.renumbered_images.end());
  std::map<std::string, const BoardObservation*> by_name;
  for (const auto& o : solved) by_name.emplace(o.filename, &o);
  std::set<std::pair<std::string, int>> outliers;
  for (const auto& o : result.outliers) outliers.emplace(o.filename, o.corner);
  const std::vector<Eigen::Vector3d> points = board_points(board, result.board_warp.value_or(BoardWarp{}));
  const Camera camera(result.camera);
  std::vector<CornerFit> fits;
  for (size_t i = 0; i < result.used_images.size(); ++i) {
    const std::string& name = result.used_images[i];
    const auto found = by_name.find(name);
    if (found == by_name.end() || found->second->corners.empty()) {
      throw Error("report: image " + name + " of the calibration has no corners among those given");
    }
    const BoardObservation& view = *found->second;
    check_observation(board, view);
    const BoardPose& pose = result.poses[i];
    for (size_t c = 0; c < view.corners.size(); ++c) {
      const int id = view.id(c);
      Eigen::Vector2d projected;
      if (!camera.project(pose.rotation * points[size_t(id)] + pose.translation, &projected)) {
        throw Error("report: corner " + std::to_string(id) + " of image " + name + " does not project");
      }
      const Eigen::Vector2d& detected = view.corners[c];
      const int in_file = renumbered.count(name) ? board.corners() - 1 - id : id;  // the file's numbering
      fits.push_back({int(i), in_file, detected, projected - detected, outliers.count({name, in_file}) > 0});
    }
  }
  return fits;
}

UncertaintyMap uncertainty_map(const Camera& camera, int step, std::optional<double> distance) {
  const CalibrationRecord* record = camera.parameters().calibration ? &*camera.parameters().calibration : nullptr;
  if (!record || record->covariance.size() == 0) throw Error("uncertainty: the camera carries no covariance");
  const int cols = (camera.width() + step - 1) / step, rows = (camera.height() + step - 1) / step;
  UncertaintyMap map{
      cv::Mat(rows, cols, CV_64F, cv::Scalar(std::nan(""))), cv::Mat(rows, cols, CV_8U, cv::Scalar(0)), {}, {}};
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector2d pixel(c * step, r * step);
      Eigen::Vector3d ray;
      if (!camera.unproject(pixel, &ray)) continue;
      const double s = projection_uncertainty(camera, pixel, distance);
      map.sigma.at<double>(r, c) = s;
      map.everywhere.push_back(s);
      if (record->observed(ray)) map.observed.at<std::uint8_t>(r, c) = 1, map.in_data.push_back(s);
    }
  }
  return map;
}

cv::Mat uncertainty_heatmap(const UncertaintyMap& map, double top, int width, int height) {
  const int rows = map.sigma.rows, cols = map.sigma.cols;
  cv::Mat scaled(rows, cols, CV_8U), colour;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double s = map.sigma.at<double>(r, c);
      scaled.at<std::uint8_t>(r, c) = std::isnan(s) ? 0 : cv::saturate_cast<std::uint8_t>(255 * s / top);
    }
  }
  cv::applyColorMap(scaled, colour, cv::COLORMAP_VIRIDIS);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      auto& px = colour.at<cv::Vec3b>(r, c);
      if (std::isnan(map.sigma.at<double>(r, c))) {
        px = {0, 0, 0};
      } else if (!map.observed.at<std::uint8_t>(r, c)) {
        px /= 2;
      }
    }
  }
  cv::Mat full;
  cv::resize(colour, full, {width, height}, 0, 0, cv::INTER_NEAREST);
  return full;
}

namespace {

constexpr double kDeg = 180 / std::numbers::pi;
constexpr int kFigureWidth = 960, kTitleHeight = 34;

std::string html_text(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string number_text(double value, const char* format = "%.4g") {
  if (std::isnan(value)) return "&ndash;";
  char text[64];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  return values[size_t(q * double(values.size() - 1))];
}

cv::Mat white(int width, int height) { return cv::Mat(height, width, CV_8UC3, cv::Scalar::all(255)); }

// A figure with a title line above its content.
cv::Mat titled(const cv::Mat& content, const std::string& title) {
  cv::Mat out = white(content.cols, content.rows + kTitleHeight);
  content.copyTo(out.rowRange(kTitleHeight, out.rows));
  draw_text(out, title, cv::Point(10, 22), -1, 0.55);
  return out;
}

// Image pixels (centres at integers) on a canvas `scale` times the image's size.
struct ImageFrame {
  double scale = 1;
  // The image fitted into a box of `box` x `box` (any aspect ratio keeps figures bounded).
  static ImageFrame fitted(int width, int height, int box) {
    return {std::min(double(box) / width, double(box) / height)};
  }
  int width(int image_width) const { return std::max(1, int(std::lround(image_width * scale))); }
  cv::Point2d at(const Eigen::Vector2d& pixel) const { return {(pixel.x() + 0.5) * scale, (pixel.y() + 0.5) * scale}; }
};

// The figures and the HTML that shows them, gathered as a report is built.
struct ReportBuilder {
  std::vector<ReportFile> files;
  std::string html;
  int figures = 0;
  void figure(const std::string& name, const cv::Mat& image, const std::string& caption) {
    files.push_back({name, encode_png(image)});
    html += "<figure><img src=\"" + html_text(name) + "\" width=\"" + std::to_string(image.cols) + "\" height=\"" +
            std::to_string(image.rows) + "\" alt=\"" + html_text(caption) + "\"><figcaption>" + html_text(caption) +
            "</figcaption></figure>\n";
    ++figures;
  }
};

// Residual arrows `gain` canvas px per px; the legend's arrow is a round residual
// at least the 95th percentile of the corners that are not outliers.
struct ArrowScale {
  double gain = 1, legend_px = 1;
};
ArrowScale arrow_scale(const std::vector<CornerFit>& fits, double canvas_width) {
  std::vector<double> lengths;
  for (const auto& f : fits) {
    if (!f.outlier) lengths.push_back(f.residual.norm());
  }
  const double p95 = quantile(lengths, 0.95);
  const double legend = p95 > 0 ? detail::tick_step(p95, 1) : 1;
  return {0.03 * canvas_width / legend, legend};
}

// Corners as dots with their residual arrows, cut at five legend lengths; outliers
// circled in red.
void draw_fits(cv::Mat& canvas, const ImageFrame& frame, const std::vector<const CornerFit*>& fits,
               const ArrowScale& arrows) {
  for (const CornerFit* f : fits) {
    const cv::Point2d at = frame.at(f->detected);
    Eigen::Vector2d arrow = f->residual * arrows.gain;
    const double cap = 5 * arrows.legend_px * arrows.gain;
    if (arrow.norm() > cap) arrow *= cap / arrow.norm();
    cv::circle(canvas, detail::sub_pixel(at), f->outlier ? 5 * 16 : 16, f->outlier ? kRed : cv::Scalar::all(150), 1,
               cv::LINE_AA, 4);
    draw_arrow(canvas, at, at + cv::Point2d(arrow.x(), arrow.y()), f->outlier ? kRed : kBlue);
  }
}

cv::Mat residual_figure(const std::vector<const CornerFit*>& fits, int width, int height, int canvas_width,
                        const ArrowScale& arrows, const std::string& title) {
  const ImageFrame frame = ImageFrame::fitted(width, height, canvas_width);
  cv::Mat canvas = white(canvas_width, frame.width(height) + 30);
  cv::rectangle(canvas, cv::Rect(0, 0, frame.width(width), canvas.rows - 30), cv::Scalar::all(180), 1);
  draw_fits(canvas, frame, fits, arrows);
  const cv::Point2d legend(12, canvas.rows - 12);
  draw_arrow(canvas, legend, legend + cv::Point2d(arrows.legend_px * arrows.gain, 0), kBlue);
  draw_text(canvas,
            fixed_text(arrows.legend_px, 3) + (canvas_width < 700 ? " px residual"
                                                                  : " px residual (projected - detected; outliers in "
                                                                    "red; arrows past 5 of these cut)"),
            cv::Point(int(legend.x + arrows.legend_px * arrows.gain) + 10, int(legend.y) + 4), -1, 0.4);
  return titled(canvas, title);
}

// The residuals' x and y components (outliers left out) against the normal density
// the solve's noise estimate predicts.
cv::Mat histogram_figure(const std::vector<CornerFit>& fits, double noise_px) {
  std::vector<double> values;
  for (const auto& f : fits) {
    if (!f.outlier) values.insert(values.end(), {f.residual.x(), f.residual.y()});
  }
  const double sigma = noise_px > 0 ? noise_px : 1;
  constexpr int kBins = 41;
  const double low = -4 * sigma, bin = 8 * sigma / kBins;
  std::vector<int> counts(kBins, 0);
  int beyond = 0;
  for (const double v : values) {
    const double at = std::floor((v - low) / bin);  // compared as a double: v may be huge
    const int b = at >= 0 && at < kBins ? int(at) : -1;
    if (b >= 0 && b < kBins) {
      ++counts[size_t(b)];
    } else {
      ++beyond;
    }
  }
  const double n = double(values.size()), peak = n * bin / (sigma * std::sqrt(2 * std::numbers::pi));
  const double top = 1.15 * std::max(peak, double(*std::max_element(counts.begin(), counts.end())));
  cv::Mat canvas = white(kFigureWidth, 380);
  const detail::PlotAxes axes{cv::Rect(80, 30, 850, 290), low, -low, 0, std::max(1.0, top)};
  detail::draw_axes(canvas, axes, "residual, x and y (px)", "corners per bin");
  for (int b = 0; b < kBins; ++b) {
    cv::rectangle(canvas, detail::sub_pixel(axes.at(low + b * bin, 0)),
                  detail::sub_pixel(axes.at(low + (b + 1) * bin, counts[size_t(b)])), cv::Scalar(225, 180, 140),
                  cv::FILLED, cv::LINE_AA, 4);
  }
  cv::Point2d previous = axes.at(low, 0);
  for (int k = 0; k <= 200; ++k) {
    const double x = low + 8 * sigma * k / 200;
    const cv::Point2d p = axes.at(x, peak * std::exp(-0.5 * x * x / (sigma * sigma)));
    if (k) detail::draw_line(canvas, previous, p, kRed, 2);
    previous = p;
  }
  draw_text(canvas,
            std::to_string(values.size()) + " values; red: the normal density of the noise estimate, sigma " +
                fixed_text(sigma, 3) + " px; " + std::to_string(beyond) + " beyond 4 sigma",
            cv::Point(80, 372), -1, 0.42);
  return titled(canvas, "Residual distribution");
}

// How many boards covered each part of the image (each board as its corners' hull).
cv::Mat coverage_figure(const std::vector<CornerFit>& fits, int images, int width, int height) {
  const ImageFrame frame = ImageFrame::fitted(width, height, kFigureWidth);
  const int rows = frame.width(height), cols = frame.width(width);
  cv::Mat count(rows, cols, CV_16U, cv::Scalar(0)), mask(rows, cols, CV_8U);
  std::vector<std::vector<cv::Point>> hulls(static_cast<size_t>(images));
  for (int i = 0; i < images; ++i) {
    std::vector<cv::Point> points;
    for (const auto& f : fits) {
      if (f.image == i) points.push_back(frame.at(f.detected));
    }
    if (points.size() < 3) continue;
    cv::convexHull(points, hulls[size_t(i)]);
    mask.setTo(0);
    cv::fillConvexPoly(mask, hulls[size_t(i)], 1);
    cv::add(count, mask, count, cv::noArray(), CV_16U);
  }
  double most = 0;
  cv::minMaxLoc(count, nullptr, &most);
  cv::Mat scaled, colour;
  count.convertTo(scaled, CV_8U, most > 0 ? 255 / most : 0);
  cv::applyColorMap(scaled, colour, cv::COLORMAP_VIRIDIS);
  colour.setTo(cv::Scalar::all(255), count == 0);
  for (const auto& hull : hulls) {
    if (!hull.empty()) cv::polylines(colour, hull, true, cv::Scalar::all(255), 1, cv::LINE_AA);
  }
  cv::Mat canvas = white(cols + 110, std::max(rows, 100));
  colour.copyTo(canvas(cv::Rect(0, 0, cols, rows)));
  cv::rectangle(canvas, cv::Rect(0, 0, cols, rows), cv::Scalar::all(180), 1);
  detail::draw_colour_bar(canvas, cv::Rect(cols + 20, 30, 22, std::max(40, canvas.rows - 60)), 0, std::max(1.0, most),
                          "boards");
  return titled(canvas, "Board coverage: how many of the " + std::to_string(images) + " boards cover each place");
}

// The sector (CalibrationRecord's 24 of 15 degrees from -180) of an azimuth.
int sector_of(double azimuth) {
  const int k = int(std::floor((azimuth + std::numbers::pi) / (2 * std::numbers::pi / kAzimuthSectors)));
  return std::clamp(k, 0, kAzimuthSectors - 1);
}

// The largest angle of incidence the image reaches per sector: every few pixels
// unprojected (the border alone misses sectors whose border lies past the lens).
AzimuthSectors image_reach(const Camera& camera) {
  AzimuthSectors reach;
  reach.fill(std::nan(""));
  const int w = camera.width(), h = camera.height(), step = std::max(1, std::max(w, h) / 240);
  for (int y = 0; y < h; y += step) {
    for (int x = 0; x < w; x += step) {
      Eigen::Vector3d ray;
      if (!camera.unproject({double(x), double(y)}, &ray)) continue;
      const int k = sector_of(std::atan2(ray.y(), ray.x()));
      const double theta = std::atan2(ray.head<2>().norm(), ray.z());
      if (!(reach[size_t(k)] >= theta)) reach[size_t(k)] = theta;
    }
  }
  return reach;
}

// Text broken into lines of at most `width` characters at spaces.
std::vector<std::string> wrapped(const std::string& text, size_t width) {
  std::vector<std::string> lines(1);
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find(' ', start);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(start, end - start);
    if (!lines.back().empty() && lines.back().size() + 1 + word.size() > width) lines.emplace_back();
    lines.back() += (lines.back().empty() ? "" : " ") + word;
    start = end + 1;
  }
  return lines;
}

// A per-sector angle as a closed outline on the polar plot (sectors without a value at the centre).
std::vector<cv::Point> sector_outline(const AzimuthSectors& angles, const cv::Point2d& centre, double px_per_rad) {
  std::vector<cv::Point> outline;
  const double width = 2 * std::numbers::pi / kAzimuthSectors;
  for (int k = 0; k < kAzimuthSectors; ++k) {
    const double r = std::isnan(angles[size_t(k)]) ? 0 : angles[size_t(k)] * px_per_rad;
    for (int j = 0; j <= 6; ++j) {
      const double azimuth = -std::numbers::pi + (k + j / 6.0) * width;
      outline.push_back(detail::sub_pixel(centre + r * cv::Point2d(std::cos(azimuth), std::sin(azimuth))));
    }
  }
  return outline;
}

// The observed angles per azimuth beside the image's reach and the camera's valid
// domain as written; the plot is oriented as the image (x right, y down).
cv::Mat domain_figure(const Camera& camera, const CalibrationRecord& record, const CameraParameters& written) {
  const AzimuthSectors reach = image_reach(camera);
  std::optional<AzimuthSectors> limit = written.theta_limit_by_azimuth;
  if (!limit && written.theta_limit) limit.emplace().fill(*written.theta_limit);
  double largest = record.theta_max;
  for (const double t : reach) largest = std::isnan(t) ? largest : std::max(largest, t);
  const double outer = std::max(90.0, std::ceil(largest * kDeg / 30) * 30) / kDeg;
  cv::Mat canvas = white(kFigureWidth, 650);
  const cv::Point2d centre(320, 310);
  const double px_per_rad = 280 / outer;
  cv::fillPoly(canvas,
               std::vector<std::vector<cv::Point>>{sector_outline(record.theta_max_by_azimuth, centre, px_per_rad)},
               cv::Scalar(240, 215, 180), cv::LINE_AA, 4);
  for (double ring = 30 / kDeg; ring <= outer + 1e-9; ring += 30 / kDeg) {
    cv::circle(canvas, detail::sub_pixel(centre), int(std::lround(ring * px_per_rad * 16)), cv::Scalar::all(200), 1,
               cv::LINE_AA, 4);
    // Labelled between the spokes, up and to the right.
    const cv::Point2d label = centre + ring * px_per_rad * cv::Point2d(std::cos(-1.18), std::sin(-1.18));
    draw_text(canvas, fixed_text(ring * kDeg, 0) + " deg", cv::Point(int(label.x) + 3, int(label.y) - 3), -1, 0.38);
  }
  for (int k = 0; k < 8; ++k) {
    const cv::Point2d direction(std::cos(k * std::numbers::pi / 4), std::sin(k * std::numbers::pi / 4));
    detail::draw_line(canvas, centre, centre + outer * px_per_rad * direction, cv::Scalar::all(215));
    draw_text(canvas, std::to_string(45 * k), centre + (outer * px_per_rad + 14) * direction + cv::Point2d(0, 4), 0,
              0.38);
  }
  const auto outline = [&](const AzimuthSectors& angles, const cv::Scalar& colour, int thickness) {
    cv::polylines(canvas, sector_outline(angles, centre, px_per_rad), true, colour, thickness, cv::LINE_AA, 4);
  };
  outline(record.theta_max_by_azimuth, kBlue, 1);
  outline(reach, kInk, 2);
  if (limit) outline(*limit, kRed, 2);
  const std::vector<std::pair<cv::Scalar, std::string>> legend = {
      {cv::Scalar(240, 215, 180), "observed: the largest angle of the corners used, per 15-degree sector"},
      {kInk, "the image's reach: the largest angle its pixels see"},
      {kRed, limit ? "the valid domain as written (theta limit)" : "no theta limit written"}};
  int y = 60;
  for (const auto& [colour, text] : legend) {
    cv::rectangle(canvas, cv::Rect(640, y - 10, 18, 12), colour, cv::FILLED);
    for (const std::string& line : wrapped(text, 38)) draw_text(canvas, line, cv::Point(666, y), -1, 0.4), y += 16;
    y += 12;
  }
  draw_text(canvas, "radius: the angle of incidence; around: the azimuth in the camera frame (degrees; x right,",
            cv::Point(20, 626), -1, 0.42);
  draw_text(canvas, "y down, as in the image)", cv::Point(20, 643), -1, 0.42);
  return titled(canvas, "Observed domain per azimuth beside the camera's");
}

// mrcal's projection uncertainty (a point at infinity) over the image.
cv::Mat uncertainty_figure(const Camera& camera, std::string* numbers) {
  const int w = camera.width(), h = camera.height();
  const UncertaintyMap map = uncertainty_map(camera, std::max(1, std::max(w, h) / 120), std::nullopt);
  const std::vector<double>& shown = map.in_data.empty() ? map.everywhere : map.in_data;
  const double top = shown.empty() ? 1 : *std::max_element(shown.begin(), shown.end());
  const ImageFrame frame = ImageFrame::fitted(w, h, kFigureWidth);
  const int rows = frame.width(h), cols = frame.width(w);
  const cv::Mat heat = uncertainty_heatmap(map, top, cols, rows);
  cv::Mat canvas = white(cols + 150, std::max(rows, 100));
  heat.copyTo(canvas(cv::Rect(0, 0, cols, rows)));
  detail::draw_colour_bar(canvas, cv::Rect(cols + 20, 30, 22, std::max(40, canvas.rows - 60)), 0, top, "px");
  *numbers = "inside the observed angles: median " + number_text(quantile(map.in_data, 0.5), "%.3g") +
             " px, 95th percentile " + number_text(quantile(map.in_data, 0.95), "%.3g") +
             " px; over the image: " + number_text(quantile(map.everywhere, 0.95), "%.3g") + " px (95th percentile)";
  return titled(canvas, "Projection uncertainty, worst direction, a point at infinity (px)");
}

// Per-image RMS, images with outliers in red with their count.
cv::Mat rms_figure(const CalibrationResult& result, const std::vector<int>& outliers) {
  const size_t n = result.per_image_rms_px.size();
  const double most = n ? *std::max_element(result.per_image_rms_px.begin(), result.per_image_rms_px.end()) : 1;
  cv::Mat canvas = white(kFigureWidth, 360);
  const detail::PlotAxes axes{cv::Rect(80, 30, 850, 270), -0.5, double(n) - 0.5, 0,
                              1.2 * std::max({most, result.rms_px, 1e-6})};
  detail::draw_axes(canvas, axes, "image (numbered as in the table below)", "rms (px)");
  for (size_t i = 0; i < n; ++i) {
    const cv::Scalar colour = outliers[i] ? kRed : kBlue;
    const cv::Point2d top = axes.at(double(i) + 0.35, result.per_image_rms_px[i]);
    cv::rectangle(canvas, detail::sub_pixel(axes.at(double(i) - 0.35, 0)), detail::sub_pixel(top), colour, cv::FILLED,
                  cv::LINE_AA, 4);
    if (outliers[i])
      draw_text(canvas, std::to_string(outliers[i]), cv::Point(int(top.x) - 4, int(top.y) - 4), 0, 0.38, kRed);
  }
  detail::draw_dashed(canvas, axes.at(-0.5, result.rms_px), axes.at(double(n) - 0.5, result.rms_px), kInk);
  draw_text(canvas, "dashed: the rms over every corner; red: images with outliers (their count above)",
            cv::Point(80, 352), -1, 0.42);
  return titled(canvas, "Per-image rms");
}

std::string row(const std::string& name, const std::string& value) {
  return "<tr><th>" + html_text(name) + "</th><td>" + value + "</td></tr>\n";
}

std::string list_html(const std::vector<std::string>& items, const char* css_class) {
  if (items.empty()) return "";
  std::string out = std::string("<ul class=\"") + css_class + "\">\n";
  for (const auto& item : items) out += "<li>" + html_text(item) + "</li>\n";
  return out + "</ul>\n";
}

std::string domain_text(const CameraParameters& written) {
  if (const auto& by_azimuth = written.theta_limit_by_azimuth) {
    const auto [low, high] = std::minmax_element(by_azimuth->begin(), by_azimuth->end());
    return "capped per azimuth at " + number_text(*low * kDeg, "%.1f") + " to " + number_text(*high * kDeg, "%.1f") +
           " deg";
  }
  if (written.theta_limit) return "capped at " + number_text(*written.theta_limit * kDeg, "%.1f") + " deg";
  return "the model's own";
}

std::string summary_html(const CalibrationResult& result, const CameraParameters& written) {
  const CameraParameters& c = result.camera;
  std::string html = "<table class=\"summary\">\n";
  html += row("model",
              html_text(std::string(model_name(c.model))) + (displaces(c.distortion) ? " with tangential terms" : ""));
  html += row("image size", std::to_string(c.width) + " &times; " + std::to_string(c.height) + " px");
  html += row("images used", std::to_string(result.used_images.size()));
  html += row("corners used", std::to_string(result.observations));
  html += row("rms", number_text(result.rms_px) + " px (2-D; " + number_text(result.rms_px / std::sqrt(2.0)) +
                         " per coordinate, as mrcal and OpenCV print it)");
  html += row("noise estimate", number_text(result.noise_px) + " px per coordinate");
  html += row("outliers", std::to_string(result.outliers.size()) + " corners (left out of the solve)");
  if (const auto& warp = result.board_warp) {
    html +=
        row("board warp", "x2 " + number_text(warp->x2) + " &plusmn; " + number_text(result.board_warp_sigma.x2) +
                              ", y2 " + number_text(warp->y2) + " &plusmn; " + number_text(result.board_warp_sigma.y2) +
                              " board units (the deflection at the board's middle; mrcal's calobject_warp)");
  } else {
    html += row("board warp", "none: the boards held flat");
  }
  if (c.calibration) {
    html += row("observed angles", "up to " + number_text(c.calibration->theta_max * kDeg, "%.1f") + " deg");
  }
  html += row("valid domain as written", domain_text(written));
  html += "</table>\n";
  html += list_html(result.warnings, "warnings");
  std::vector<std::string> undetermined;
  for (const auto& text : result.undetermined) undetermined.push_back("not determined by the data: " + text);
  return html + list_html(undetermined, "warnings");
}

std::string parameters_html(const CalibrationResult& result) {
  // locate_boards (fishcam report) holds the camera: its sigmas are 0, not estimates.
  const bool estimated = std::any_of(result.sigmas.begin(), result.sigmas.end(), [](double v) { return v != 0; });
  std::string html =
      "<h3>Parameters</h3>\n<table class=\"parameters\">\n<tr><th>name</th><th>value</th>"
      "<th>1-sigma</th></tr>\n";
  for (size_t i = 0; i < result.parameters.size(); ++i) {
    html += "<tr><td>" + html_text(result.parameter_names[i]) + "</td><td class=\"n\">" +
            number_text(result.parameters[i], "%.10g") + "</td><td class=\"n\">" +
            (!estimated                     ? std::string("&ndash;")
             : std::isnan(result.sigmas[i]) ? std::string("not determined")
                                            : number_text(result.sigmas[i], "%.3g")) +
            "</td></tr>\n";
  }
  html += "</table>\n";
  if (!estimated) {
    html +=
        "<p>The camera as given, its boards located with its intrinsics held (and the boards flat): no sigma is "
        "estimated here (the calibration's own are in its file: <code>fishcam info</code>), and the residuals are "
        "those of the located boards, not necessarily the calibration's.</p>\n";
  }
  return html;
}

std::string images_html(const CalibrationResult& result, const std::vector<int>& outliers) {
  std::string html =
      "<h3>Images</h3>\n<table class=\"images\">\n<tr><th>#</th><th>image</th><th>rms (px)</th>"
      "<th>outliers</th></tr>\n";
  for (size_t i = 0; i < result.used_images.size(); ++i) {
    html += "<tr><td class=\"n\">" + std::to_string(i) + "</td><td>" + html_text(result.used_images[i]) +
            "</td><td class=\"n\">" + number_text(result.per_image_rms_px[i], "%.3f") + "</td><td class=\"n\">" +
            std::to_string(outliers[i]) + "</td></tr>\n";
  }
  html += "</table>\n";
  if (result.outliers.empty()) return html;
  html += "<h3>Outliers</h3>\n<table class=\"outliers\">\n<tr><th>image</th><th>corner</th><th>error (px)</th></tr>\n";
  for (const auto& o : result.outliers) {
    html += "<tr><td>" + html_text(o.filename) + "</td><td class=\"n\">" + std::to_string(o.corner) +
            "</td><td class=\"n\">" + number_text(o.error_px, "%.2f") + "</td></tr>\n";
  }
  return html + "</table>\n";
}

// One camera's section: its numbers, figures (named prefix...) and tables.
void camera_section(const CalibrationResult& result, const CameraParameters& written,
                    const std::vector<BoardObservation>& observations, const BoardSpec& board,
                    const std::string& prefix, ReportBuilder* out) {
  const std::vector<CornerFit> fits = corner_fits(result, observations, board);
  const int images = int(result.used_images.size()), w = result.camera.width, h = result.camera.height;
  std::vector<int> outliers(size_t(images), 0);
  std::vector<std::vector<const CornerFit*>> per_image(static_cast<size_t>(images));
  std::vector<const CornerFit*> all;
  for (const auto& f : fits) {
    outliers[size_t(f.image)] += f.outlier, per_image[size_t(f.image)].push_back(&f), all.push_back(&f);
  }
  out->html += summary_html(result, written) + parameters_html(result);
  out->figure(prefix + "residuals.png",
              residual_figure(all, w, h, kFigureWidth, arrow_scale(fits, kFigureWidth), "Residuals over the image"),
              "Every corner's residual (projected minus detected), arrows scaled as the legend says.");
  out->figure(prefix + "per-image-rms.png", rms_figure(result, outliers), "Per-image rms; outliers marked.");
  out->figure(prefix + "histogram.png", histogram_figure(fits, result.noise_px),
              "The residuals' components against the normal distribution of the noise estimate.");
  out->figure(prefix + "coverage.png", coverage_figure(fits, images, w, h),
              "Where the boards were: the image's parts no board covered constrain the model least.");
  const Camera camera(result.camera);
  if (result.camera.calibration) {
    out->figure(prefix + "domain.png", domain_figure(camera, *result.camera.calibration, written),
                "The angles the corners reached per azimuth, beside the image's reach and the valid domain written.");
  } else {
    out->html += "<p>No observed-domain figure: the camera carries no calibration record.</p>\n";
  }
  if (result.camera.calibration && result.camera.calibration->covariance.size() > 0) {
    std::string numbers;
    const cv::Mat figure = uncertainty_figure(camera, &numbers);
    out->figure(prefix + "uncertainty.png", figure,
                "Projection uncertainty (mrcal's definition); dimmed outside the observed angles, black: no ray; the "
                "colours end at the largest value inside the observed angles (larger ones beyond them are clipped). " +
                    numbers + ".");
  } else {
    out->html +=
        "<p>No projection-uncertainty map: the camera carries no covariance (fishcam calibrate writes one "
        "into fishcam JSON; other formats cannot hold it).</p>\n";
  }
  out->html += images_html(result, outliers) + "<h3>Residuals per image</h3>\n<div class=\"small\">\n";
  const ArrowScale small = arrow_scale(fits, 480);
  for (int i = 0; i < images; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "image-%03d.png", i);
    out->figure(
        prefix + name,
        residual_figure(per_image[size_t(i)], w, h, 480, small,
                        "#" + std::to_string(i) + " rms " + fixed_text(result.per_image_rms_px[size_t(i)], 3) + " px"),
        "#" + std::to_string(i) + ": " + result.used_images[size_t(i)]);
  }
  out->html += "</div>\n";
}

std::string page(const std::string& title, const ReportBuilder& body) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" + html_text(title) +
         "</title>\n<style>\nbody{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}\n"
         "table{border-collapse:collapse;margin:0.5em 0}\ntd,th{padding:2px 10px;text-align:left;"
         "border-bottom:1px solid #ddd}\ntd.n{text-align:right;font-variant-numeric:tabular-nums}\n"
         "figure{margin:1.5em 0}\nimg{max-width:100%;height:auto}\n.small figure{display:inline-block;width:32%;"
         "margin:0.3em 0}\n.small figcaption{font-size:80%}\n.warnings{color:#a40}\n#missing{color:#b00;"
         "font-weight:bold}\n</style>\n</head>\n<body data-figures=\"" +
         std::to_string(body.figures) + "\">\n<h1>" + html_text(title) + "</h1>\n<p id=\"missing\" hidden></p>\n" +
         body.html +
         "<script>\n// Say so when figures are missing (the PNG files belong beside this page).\n"
         "window.addEventListener('load', function () {\n"
         "  var images = Array.prototype.slice.call(document.images);\n"
         "  var loaded = images.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;\n"
         "  document.body.setAttribute('data-figures-loaded', String(loaded));\n"
         "  if (loaded < images.length) {\n"
         "    var m = document.getElementById('missing');\n"
         "    m.hidden = false;\n"
         "    m.textContent = (images.length - loaded) + ' of ' + images.length +\n"
         "        ' figures did not load: keep the PNG files beside this page.';\n"
         "  }\n"
         "});\n</script>\n</body>\n</html>\n";
}

// Each instant's relative pose camera 0 -> camera k, from each camera's own boards
// (located with its intrinsics), against the joint solve's: rotation (deg) and
// translation (board units) differences, by instant name.
struct InstantDifferences {
  std::map<std::string, std::pair<double, double>> by_instant;
  std::string error;  // why there are none (a camera whose boards could not be located)
};
InstantDifferences instant_differences(const RigCalibrationResult& rig, size_t k,
                                       const std::vector<std::vector<BoardObservation>>& observations,
                                       const BoardSpec& board) {
  InstantDifferences out;
  std::array<std::map<std::string, Pose>, 2> seen;  // camera 0's and camera k's boards by instant
  try {
    for (const size_t camera : {size_t(0), k}) {
      const CalibrationResult located = locate_boards(as_solved(rig.cameras[camera], observations[camera], board),
                                                      board, Camera(rig.cameras[camera].camera));
      for (size_t b = 0; b < located.used_images.size(); ++b) {
        seen[camera ? 1 : 0][std::filesystem::path(located.used_images[b]).filename().string()] = located.poses[b];
      }
    }
  } catch (const Error& e) {
    out.error = e.what();
    return out;
  }
  const Pose joint = inverse(*rig.cameras[k].camera.pose);  // camera 0 -> k
  for (const auto& [instant, board_in_0] : seen[0]) {
    const auto found = seen[1].find(instant);
    if (found == seen[1].end()) continue;
    const Pose relative = compose(found->second, inverse(board_in_0));
    const double angle = Eigen::AngleAxisd(relative.rotation * joint.rotation.inverse()).angle() * kDeg;
    out.by_instant[instant] = {angle, (relative.translation - joint.translation).norm()};
  }
  return out;
}

cv::Mat instants_figure(const std::vector<InstantDifferences>& cameras, const std::vector<std::string>& instants) {
  const std::array<cv::Scalar, 4> colours = {kBlue, kRed, detail::kGreen, kInk};
  cv::Mat canvas = white(kFigureWidth, 620);
  for (int panel = 0; panel < 2; ++panel) {
    double top = 0;
    for (const auto& c : cameras) {
      for (const auto& [name, d] : c.by_instant) top = std::max(top, panel ? d.second : d.first);
    }
    // At least 0.01 deg and 1e-4 board units tall: exact data need no axis at 1e-10.
    const detail::PlotAxes axes{cv::Rect(80, 30 + 300 * panel, 850, 220), -0.5, double(instants.size()) - 0.5, 0,
                                1.2 * std::max(top, panel ? 1e-4 : 0.01)};
    detail::draw_axes(canvas, axes, "instant (numbered as in the table below)",
                      panel ? "translation difference (board units)" : "rotation difference (deg)");
    for (size_t k = 0; k < cameras.size(); ++k) {
      for (size_t i = 0; i < instants.size(); ++i) {
        const auto found = cameras[k].by_instant.find(instants[i]);
        if (found == cameras[k].by_instant.end()) continue;
        const double value = panel ? found->second.second : found->second.first;
        cv::circle(canvas, detail::sub_pixel(axes.at(double(i), value)), 4 * 16, colours[k % colours.size()],
                   cv::FILLED, cv::LINE_AA, 4);
      }
      draw_text(canvas, "camera " + std::to_string(k + 1), cv::Point(820, 50 + 16 * int(k)), -1, 0.4,
                colours[k % colours.size()]);
    }
  }
  return titled(canvas, "Each instant's relative pose against the joint solve's");
}

std::string instants_html(const std::vector<InstantDifferences>& cameras, const std::vector<std::string>& instants) {
  std::string html = "<table class=\"instants\">\n<tr><th>#</th><th>instant</th>";
  for (size_t k = 0; k < cameras.size(); ++k) {
    html += "<th>camera " + std::to_string(k + 1) + ": rotation (deg)</th><th>translation</th>";
  }
  html += "</tr>\n";
  for (size_t i = 0; i < instants.size(); ++i) {
    html += "<tr><td class=\"n\">" + std::to_string(i) + "</td><td>" + html_text(instants[i]) + "</td>";
    for (const auto& c : cameras) {
      const auto found = c.by_instant.find(instants[i]);
      const bool seen = found != c.by_instant.end();
      html += "<td class=\"n\">" + (seen ? number_text(found->second.first, "%.3f") : std::string("&ndash;")) +
              "</td><td class=\"n\">" + (seen ? number_text(found->second.second, "%.4g") : std::string("&ndash;")) +
              "</td>";
    }
    html += "</tr>\n";
  }
  return html + "</table>\n";
}

}  // namespace
}  // namespace fishcam

namespace fishcam {

std::vector<ReportFile> calibration_report(const CalibrationResult& result, const CameraParameters& written,
                                           const std::vector<BoardObservation>& observations, const BoardSpec& board,
                                           const std::string& title) {
  ReportBuilder builder;
  camera_section(result, written, observations, board, "", &builder);
  builder.files.insert(builder.files.begin(), {"index.html", page("Calibration report: " + title, builder)});
  return builder.files;
}

std::vector<ReportFile> rig_calibration_report(const RigCalibrationResult& rig,
                                               const std::vector<CameraParameters>& written,
                                               const std::vector<std::vector<BoardObservation>>& observations,
                                               const BoardSpec& board, const std::vector<std::string>& titles) {
  const size_t n = rig.cameras.size();
  if (written.size() != n || observations.size() != n || titles.size() != n) {
    throw Error("report: give the written camera, the corners and a title for each of the rig's " + std::to_string(n) +
                " cameras");
  }
  ReportBuilder builder;
  builder.html += "<table class=\"summary\">\n" + row("cameras", std::to_string(n)) +
                  row("instants", std::to_string(rig.instants)) +
                  row("rms", number_text(rig.rms_px) + " px (2-D, every camera's corners)") + "</table>\n" +
                  list_html(rig.warnings, "warnings");
  std::vector<InstantDifferences> differences;
  std::set<std::string> names;
  for (size_t k = 1; k < n; ++k) {
    differences.push_back(instant_differences(rig, k, observations, board));
    for (const auto& [name, d] : differences.back().by_instant) names.insert(name);
    if (!differences.back().error.empty()) {
      builder.html += "<p class=\"warnings\">camera " + std::to_string(k) + ": no per-instant poses (" +
                      html_text(differences.back().error) + ")</p>\n";
    }
  }
  const std::vector<std::string> instants(names.begin(), names.end());
  builder.html += "<h2>Instants</h2>\n";
  builder.figure("instants.png", instants_figure(differences, instants),
                 "Per instant, where camera k sits relative to camera 0 by that instant's boards alone (each camera's "
                 "boards located with its intrinsics), against the joint solve: scatter here is what the joint solve "
                 "averages (pairs not taken at the same time, a moved camera).");
  builder.html += instants_html(differences, instants);
  for (size_t k = 0; k < n; ++k) {
    builder.html += "<h2>Camera " + std::to_string(k) + ": " + html_text(titles[k]) +
                    (rig.fixed_intrinsics[k] ? " (intrinsics held fixed)" : "") + "</h2>\n";
    camera_section(rig.cameras[k], written[k], observations[k], board, "camera" + std::to_string(k) + "-", &builder);
  }
  builder.files.insert(builder.files.begin(), {"index.html", page("Rig calibration report", builder)});
  return builder.files;
}

}  // namespace fishcam
