#include "report_figures.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace fishcam::detail {

namespace {
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

// Digits after the point that tell ticks `step` apart.
int digits_for(double step) { return std::max(0, int(-std::floor(std::log10(step) + 1e-9))); }
}  // namespace

std::string fixed_text(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  const std::string out = text;
  // No "-0.0": a value that rounds to zero is zero.
  return out.find_first_not_of("-0.") == std::string::npos && out[0] == '-' ? out.substr(1) : out;
}

void draw_text(cv::Mat& canvas, const std::string& text, cv::Point at, int align, double scale,
               const cv::Scalar& colour) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  if (align == 0) at.x -= size.width / 2;
  if (align > 0) at.x -= size.width;
  cv::putText(canvas, text, at, kFont, scale, colour, 1, cv::LINE_AA);
}

double tick_step(double span, int count) {
  if (!(span > 0) || !std::isfinite(span)) return 1;
  const double raw = span / count, power = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * power >= raw) return m * power;
  }
  return 10 * power;
}

cv::Point2d PlotAxes::at(double x, double y) const {
  return {area.x + (x - x0) / (x1 - x0) * area.width, area.y + area.height - (y - y0) / (y1 - y0) * area.height};
}

void draw_axes(cv::Mat& canvas, const PlotAxes& axes, const std::string& x_label, const std::string& y_label) {
  const double dx = tick_step(axes.x1 - axes.x0), dy = tick_step(axes.y1 - axes.y0);
  for (double x = std::ceil(axes.x0 / dx - 1e-9) * dx; x <= axes.x1 + 1e-9 * dx; x += dx) {
    const cv::Point2d p = axes.at(x, axes.y0);
    draw_line(canvas, p, axes.at(x, axes.y1), kGridLine);
    draw_text(canvas, fixed_text(x, digits_for(dx)), cv::Point(int(p.x), int(p.y) + 16), 0, 0.4);
  }
  for (double y = std::ceil(axes.y0 / dy - 1e-9) * dy; y <= axes.y1 + 1e-9 * dy; y += dy) {
    const cv::Point2d p = axes.at(axes.x0, y);
    draw_line(canvas, p, axes.at(axes.x1, y), kGridLine);
    draw_text(canvas, fixed_text(y, digits_for(dy)), cv::Point(int(p.x) - 6, int(p.y) + 4), 1, 0.4);
  }
  cv::rectangle(canvas, axes.area, kInk, 1);
  draw_text(canvas, x_label, cv::Point(axes.area.x + axes.area.width / 2, axes.area.br().y + 36), 0);
  draw_text(canvas, y_label, cv::Point(axes.area.x, axes.area.y - 10), -1);
}

cv::Point sub_pixel(const cv::Point2d& p) { return {int(std::lround(p.x * 16)), int(std::lround(p.y * 16))}; }

void draw_line(cv::Mat& canvas, const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour, int thickness) {
  cv::line(canvas, sub_pixel(a), sub_pixel(b), colour, thickness, cv::LINE_AA, 4);
}

void draw_arrow(cv::Mat& canvas, const cv::Point2d& from, const cv::Point2d& to, const cv::Scalar& colour) {
  const double length = cv::norm(to - from);
  if (length < 0.5) return;
  // Heads of a fixed size (OpenCV's scale with the arrow, invisible on short ones).
  cv::arrowedLine(canvas, sub_pixel(from), sub_pixel(to), colour, 1, cv::LINE_AA, 4, std::min(0.5, 4 / length));
}

void draw_dashed(cv::Mat& canvas, const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour) {
  const double length = cv::norm(b - a);
  for (double s = 0; s < length; s += 14) {
    draw_line(canvas, a + (b - a) * (s / length), a + (b - a) * (std::min(length, s + 8) / length), colour, 2);
  }
}

void draw_colour_bar(cv::Mat& canvas, const cv::Rect& area, double low, double top, const std::string& unit) {
  cv::Mat ramp(area.height, 1, CV_8U), colours;
  for (int r = 0; r < area.height; ++r)
    ramp.at<unsigned char>(r) =
        cv::saturate_cast<unsigned char>(255.0 * (area.height - 1 - r) / std::max(1, area.height - 1));
  cv::applyColorMap(ramp, colours, cv::COLORMAP_VIRIDIS);
  cv::Mat bar = canvas(area);  // same size and type: resized in place
  cv::resize(colours, bar, area.size(), 0, 0, cv::INTER_NEAREST);
  cv::rectangle(canvas, area, kInk, 1);
  const PlotAxes axes{area, 0, 1, low, top};
  const double step = tick_step(top - low, 4);
  for (double v = std::ceil(low / step - 1e-9) * step; v <= top + 1e-9 * step; v += step) {
    const cv::Point2d p = axes.at(1, v);
    draw_line(canvas, p, p + cv::Point2d(4, 0), kInk);
    draw_text(canvas, fixed_text(v, digits_for(step)), cv::Point(int(p.x) + 7, int(p.y) + 4), -1, 0.4);
  }
  draw_text(canvas, unit, cv::Point(area.x, area.y - 8), -1, 0.4);
}

}  // namespace fishcam::detail
