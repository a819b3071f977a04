// Drawing the calibration report's figures with OpenCV (calibration_report.cpp):
// axes with round ticks, text, arrows and colour bars on white canvases.
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace fishcam::detail {

inline const cv::Scalar kInk(40, 40, 40), kGridLine(228, 228, 228), kBlue(190, 110, 30), kRed(40, 40, 210),
    kPale(250, 232, 214), kGreen(60, 150, 40);

// "%.*f" of a value: digits after the point.
std::string fixed_text(double value, int digits);
// Text at `at` (its baseline), aligned left (-1), centred (0) or right (1).
void draw_text(cv::Mat& canvas, const std::string& text, cv::Point at, int align = -1, double scale = 0.45,
               const cv::Scalar& colour = kInk);
// A round step (1, 2 or 5 times a power of ten) giving about `count` ticks over span.
double tick_step(double span, int count = 5);

// A plot's area on a canvas and the data range it shows (y up).
struct PlotAxes {
  cv::Rect area;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  cv::Point2d at(double x, double y) const;
};
// Grid lines and tick labels at round values, a frame, the axis labels.
void draw_axes(cv::Mat& canvas, const PlotAxes& axes, const std::string& x_label, const std::string& y_label);

// Sub-pixel drawing: the points in 1/16 px (OpenCV's shift 4).
cv::Point sub_pixel(const cv::Point2d& p);
void draw_line(cv::Mat& canvas, const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour,
               int thickness = 1);
void draw_arrow(cv::Mat& canvas, const cv::Point2d& from, const cv::Point2d& to, const cv::Scalar& colour);
// A dashed line (legends and reference values).
void draw_dashed(cv::Mat& canvas, const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& colour);

// A vertical viridis bar for [0, top] at `area`, labelled with `unit`.
void draw_colour_bar(cv::Mat& canvas, const cv::Rect& area, double low, double top, const std::string& unit);

}  // namespace fishcam::detail
