#include "fishcam/eval/metrics.hpp"

#include <numeric>

#include "fishcam/core/error.hpp"

namespace fishcam {
namespace {

// The matrix has num_classes^2 counters: 1024 classes are 8 MB.
constexpr int kMaxClasses = 1024;

std::size_t size_of(const LabelSpan& labels) {
  return std::visit([](const auto& s) { return s.size(); }, labels);
}

std::string where(std::size_t index, int width) {
  if (width <= 0) return "at index " + std::to_string(index);
  return "at pixel (" + std::to_string(index % std::size_t(width)) + ", " + std::to_string(index / std::size_t(width)) +
         ")";
}

LabelSpan span_of(const cv::Mat& image, const char* what) {
  if (image.channels() != 1) throw Error(std::string(what) + ": expected a single-channel label image");
  const cv::Mat& m = image;
  if (!m.isContinuous()) throw Error(std::string(what) + ": expected a continuous image");
  const std::size_t n = m.total();
  switch (m.depth()) {
    case CV_8U:
      return std::span<const std::uint8_t>(m.ptr<std::uint8_t>(), n);
    case CV_16U:
      return std::span<const std::uint16_t>(m.ptr<std::uint16_t>(), n);
    case CV_32S:
      return std::span<const std::int32_t>(m.ptr<std::int32_t>(), n);
    default:
      throw Error(std::string(what) + ": expected 8- or 16-bit unsigned or 32-bit signed labels");
  }
}

}  // namespace

ConfusionMatrix::ConfusionMatrix(int num_classes, std::optional<std::int64_t> ignore)
    : num_classes_(num_classes), ignore_(ignore) {
  if (num_classes < 1 || num_classes > kMaxClasses) {
    throw Error("num_classes: expected 1 to " + std::to_string(kMaxClasses) + ", got " + std::to_string(num_classes));
  }
  counts_.assign(std::size_t(num_classes) * std::size_t(num_classes), 0);
}

void ConfusionMatrix::update(const LabelSpan& prediction, const LabelSpan& ground_truth,
                             std::span<const std::uint8_t> valid, int width) {
  const std::size_t n = size_of(prediction);
  if (size_of(ground_truth) != n) {
    throw Error("prediction has " + std::to_string(n) + " pixels but the ground truth " +
                std::to_string(size_of(ground_truth)));
  }
  if (!valid.empty() && valid.size() != n) {
    throw Error("the validity mask has " + std::to_string(valid.size()) + " pixels but the prediction " +
                std::to_string(n));
  }
  const std::int64_t classes = num_classes_;
  std::visit(
      [&](const auto& pred, const auto& gt) {
        const bool has_ignore = ignore_.has_value();
        const std::int64_t ignore = ignore_.value_or(-1);
        auto scored = [&](std::size_t i) {
          return (valid.empty() || valid[i]) && !(has_ignore && std::int64_t(gt[i]) == ignore);
        };
        // Everything is checked before anything is counted: a bad image leaves the matrix as it was.
        for (std::size_t i = 0; i < n; ++i) {
          if (!scored(i)) continue;
          const std::int64_t t = std::int64_t(gt[i]), p = std::int64_t(pred[i]);
          if (t < 0 || t >= classes) {
            throw Error("ground truth value " + std::to_string(t) + " " + where(i, width) + " is not a class (0 to " +
                        std::to_string(classes - 1) + (has_ignore ? ", ignored: " + std::to_string(ignore) : "") + ")");
          }
          if (p < 0 || p >= classes) {
            throw Error("prediction value " + std::to_string(p) + " " + where(i, width) + " is not a class (0 to " +
                        std::to_string(classes - 1) + ")");
          }
        }
        for (std::size_t i = 0; i < n; ++i) {
          if (scored(i)) ++counts_[std::size_t(gt[i]) * std::size_t(classes) + std::size_t(pred[i])];
        }
      },
      prediction, ground_truth);
}

void ConfusionMatrix::update(const cv::Mat& prediction, const cv::Mat& ground_truth, const cv::Mat& valid) {
  if (prediction.size() != ground_truth.size()) {
    throw Error("prediction is " + std::to_string(prediction.cols) + "x" + std::to_string(prediction.rows) +
                " but the ground truth " + std::to_string(ground_truth.cols) + "x" + std::to_string(ground_truth.rows));
  }
  std::span<const std::uint8_t> mask;
  if (!valid.empty()) {
    if (valid.type() != CV_8UC1 || valid.size() != prediction.size() || !valid.isContinuous()) {
      throw Error("validity mask: expected an 8-bit single-channel image of the prediction's size");
    }
    mask = std::span<const std::uint8_t>(valid.ptr<std::uint8_t>(), valid.total());
  }
  update(span_of(prediction, "prediction"), span_of(ground_truth, "ground truth"), mask, prediction.cols);
}

void ConfusionMatrix::merge(const ConfusionMatrix& other) {
  if (other.num_classes_ != num_classes_ || other.ignore_ != ignore_) {
    throw Error("merge: confusion matrices of different classes or ignore values");
  }
  for (std::size_t i = 0; i < counts_.size(); ++i) counts_[i] += other.counts_[i];
}

std::int64_t ConfusionMatrix::scored_pixels() const {
  return std::accumulate(counts_.begin(), counts_.end(), std::int64_t{0});
}

std::vector<std::optional<double>> ConfusionMatrix::iou() const {
  std::vector<std::optional<double>> out(static_cast<std::size_t>(num_classes_));
  for (int c = 0; c < num_classes_; ++c) {
    std::int64_t truth = 0, predicted = 0;  // row and column sums
    for (int k = 0; k < num_classes_; ++k) truth += count(c, k), predicted += count(k, c);
    const std::int64_t tp = count(c, c);
    const std::int64_t union_ = truth + predicted - tp;  // TP + FN + FP
    if (union_ > 0) out[std::size_t(c)] = double(tp) / double(union_);
  }
  return out;
}

std::optional<double> ConfusionMatrix::miou() const {
  double sum = 0;
  int present = 0;
  for (const auto& value : iou()) {
    if (value) sum += *value, ++present;
  }
  if (present == 0) return std::nullopt;
  return sum / present;
}

}  // namespace fishcam
