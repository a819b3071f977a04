#include "fishcam/fidelity.hpp"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>

namespace fishcam {

Fidelity augmentation_fidelity(const ViewpointWarp& warp, const ViewpointChange& change,
                               std::optional<DepthPrior> prior, const cv::Mat& source_image,
                               const cv::Mat& source_labels, const cv::Mat& source_depth,
                               const cv::Mat& truth_image, const cv::Mat& truth_labels) {
  const cv::Size out(warp.target().width(), warp.target().height());
  if (source_image.type() != CV_8UC3 || truth_image.type() != CV_8UC3 || source_labels.type() != CV_8UC1 ||
      truth_labels.type() != CV_8UC1) {
    throw Error("fidelity: expected 8-bit 3-channel images and 8-bit labels");
  }
  if (truth_image.size() != out || truth_labels.size() != out) {
    throw Error("fidelity: the truth is not the output camera's size");
  }
  WarpMaps maps;
  if (prior) {
    warp.compute(change, *prior, &maps);
  } else {
    if (source_depth.empty()) throw Error("fidelity: the depth-map prior needs the source's depth map");
    warp.compute_from_depth(change, source_depth, DepthValues::range, &maps);
  }
  cv::Mat image, labels;
  warp_image(source_image, maps, &image);
  warp_labels(source_labels, maps, 255, &labels);
  // Away from boundaries: one label in the truth's 5 x 5 neighbourhood, and a source
  // all around.
  const cv::Mat kernel = cv::Mat::ones(5, 5, CV_8U);
  cv::Mat low, high, valid_inner;
  cv::erode(truth_labels, low, kernel);
  cv::dilate(truth_labels, high, kernel);
  const cv::Mat valid = maps.validity();
  cv::erode(valid, valid_inner, kernel);
  const cv::Mat where = (low == high) & (valid_inner != 0);
  Fidelity f;
  f.valid_share = cv::countNonZero(valid) / double(valid.total());
  f.compared = cv::countNonZero(where);
  if (f.compared == 0) {
    f.label_agreement = f.psnr_db = std::numeric_limits<double>::quiet_NaN();
    return f;
  }
  f.label_agreement = cv::countNonZero((labels == truth_labels) & where) / double(f.compared);
  cv::Mat difference;
  cv::absdiff(image, truth_image, difference);
  difference.convertTo(difference, CV_64FC3);
  cv::Mat squared = difference.mul(difference);
  squared.setTo(cv::Scalar::all(0), where == 0);
  const cv::Scalar sum = cv::sum(squared);
  const double mse = (sum[0] + sum[1] + sum[2]) / (3.0 * double(f.compared));
  f.psnr_db = mse > 0 ? 10 * std::log10(255.0 * 255.0 / mse) : std::numeric_limits<double>::infinity();
  return f;
}

}  // namespace fishcam
