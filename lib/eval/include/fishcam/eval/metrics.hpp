// Segmentation metrics the paper's way (eqs. 11-12): one confusion matrix over
// every pixel of a test set, IoU per class from it, mIoU as their mean.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

namespace fishcam {

// Label values of any of the integer types predictions and ground truths come in
// (PNG labels: uint8/uint16; argmax of a network's output: int64).
using LabelSpan = std::variant<std::span<const std::uint8_t>, std::span<const std::uint16_t>,
                               std::span<const std::int32_t>, std::span<const std::int64_t>>;

class ConfusionMatrix {
 public:
  // Classes 0 .. num_classes - 1 (1 to 65536). Ground-truth pixels equal to
  // `ignore` are not scored; the value may lie outside the classes (255 is common).
  explicit ConfusionMatrix(int num_classes, std::optional<std::int64_t> ignore = std::nullopt);

  // Adds equally long prediction and ground-truth arrays (one image, or a batch
  // flattened). `valid`, when not empty, is as long and only pixels where it is
  // non-zero are scored. `width`, when > 0, makes errors name pixels as (x, y).
  // A ground-truth value that is neither `ignore` nor a class, or a prediction
  // that is not a class (on a scored pixel), throws Error and leaves the matrix
  // unchanged.
  void update(const LabelSpan& prediction, const LabelSpan& ground_truth, std::span<const std::uint8_t> valid = {},
              int width = 0);
  // The same for images: single-channel CV_8U, CV_16U or CV_32S of equal size;
  // `valid` empty or CV_8UC1 of that size.
  void update(const cv::Mat& prediction, const cv::Mat& ground_truth, const cv::Mat& valid = cv::Mat());
  void merge(const ConfusionMatrix& other);

  int num_classes() const { return num_classes_; }
  std::optional<std::int64_t> ignore() const { return ignore_; }
  // Pixels of ground-truth class `truth` predicted as `predicted`.
  std::int64_t count(int truth, int predicted) const {
    return counts_[std::size_t(truth) * std::size_t(num_classes_) + std::size_t(predicted)];
  }
  // Row-major num_classes x num_classes, rows: ground truth, columns: prediction.
  const std::vector<std::int64_t>& counts() const { return counts_; }
  std::int64_t scored_pixels() const;

  // IoU_n = TP / (TP + FP + FN) (eq. 11), in [0, 1]; nullopt for a class absent
  // from both prediction and ground truth (0 / 0: no evidence either way).
  std::vector<std::optional<double>> iou() const;
  // Eq. 12 over the classes with an IoU (absent classes are left out of the
  // mean); nullopt when no pixel was scored.
  std::optional<double> miou() const;

 private:
  int num_classes_;
  std::optional<std::int64_t> ignore_;
  std::vector<std::int64_t> counts_;
};

}  // namespace fishcam
