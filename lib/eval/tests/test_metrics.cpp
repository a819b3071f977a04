// The confusion matrix, IoU and mIoU (the paper's eqs. 11-12) against hand-worked values.
#include <gtest/gtest.h>

#include "fishcam/core/error.hpp"
#include "fishcam/eval/metrics.hpp"

namespace fishcam {
namespace {

template <class T>
std::span<const T> span(const std::vector<T>& v) {
  return std::span<const T>(v.data(), v.size());
}

TEST(Metrics, HandWorkedConfusionMatrix) {
  // Three classes; ground truth / prediction per pixel, one ignored pixel (255).
  const std::vector<std::uint8_t> gt{0, 0, 1, 1, 1, 2, 2, 255};
  const std::vector<std::int64_t> pred{0, 1, 1, 1, 2, 2, 0, 7};  // the ignored pixel's 7 is never checked
  ConfusionMatrix m(3, 255);
  m.update(span(pred), span(gt));
  // rows: truth; columns: prediction
  const std::vector<std::int64_t> expected{1, 1, 0,  //
                                           0, 2, 1,  //
                                           1, 0, 1};
  EXPECT_EQ(m.counts(), expected);
  EXPECT_EQ(m.scored_pixels(), 7);
  const auto iou = m.iou();
  // class 0: TP 1, FN 1, FP 1 -> 1/3; class 1: TP 2, FN 1, FP 1 -> 2/4; class 2: TP 1, FN 1, FP 1 -> 1/3
  EXPECT_DOUBLE_EQ(*iou[0], 1.0 / 3);
  EXPECT_DOUBLE_EQ(*iou[1], 0.5);
  EXPECT_DOUBLE_EQ(*iou[2], 1.0 / 3);
  EXPECT_DOUBLE_EQ(*m.miou(), (1.0 / 3 + 0.5 + 1.0 / 3) / 3);
}

TEST(Metrics, AbsentClassesAreLeftOutOfTheMean) {
  const std::vector<std::uint16_t> gt{0, 0, 2, 2};
  const std::vector<std::uint16_t> pred{0, 0, 2, 0};
  ConfusionMatrix m(4);
  m.update(span(pred), span(gt));
  const auto iou = m.iou();
  EXPECT_FALSE(iou[1].has_value());
  EXPECT_FALSE(iou[3].has_value());
  EXPECT_DOUBLE_EQ(*iou[0], 2.0 / 3);
  EXPECT_DOUBLE_EQ(*iou[2], 0.5);
  EXPECT_DOUBLE_EQ(*m.miou(), (2.0 / 3 + 0.5) / 2);
  // A class predicted but absent from the ground truth has IoU 0 and counts.
  ConfusionMatrix fp(4);
  fp.update(span(std::vector<std::uint8_t>{3}), span(std::vector<std::uint8_t>{0}));
  EXPECT_DOUBLE_EQ(*fp.iou()[3], 0.0);
  EXPECT_DOUBLE_EQ(*fp.miou(), 0.0);
  EXPECT_FALSE(ConfusionMatrix(2).miou().has_value());
}

TEST(Metrics, ValidityMaskAndMatsAndMerge) {
  cv::Mat gt = (cv::Mat_<std::uint8_t>(2, 2) << 0, 1, 1, 1);
  cv::Mat pred = (cv::Mat_<std::uint8_t>(2, 2) << 0, 1, 0, 0);
  cv::Mat valid = (cv::Mat_<std::uint8_t>(2, 2) << 1, 1, 0, 0);
  ConfusionMatrix a(2), b(2);
  a.update(pred, gt, valid);
  EXPECT_DOUBLE_EQ(*a.miou(), 1.0);
  b.update(pred, gt);
  a.merge(b);
  EXPECT_EQ(a.count(1, 0), 2);
  EXPECT_EQ(a.count(0, 0), 2);
  EXPECT_EQ(a.count(1, 1), 2);
  EXPECT_THROW(a.merge(ConfusionMatrix(3)), Error);
}

TEST(Metrics, BadInputThrowsAndLeavesTheMatrixUnchanged) {
  ConfusionMatrix m(3, 255);
  m.update(span(std::vector<std::uint8_t>{0, 1}), span(std::vector<std::uint8_t>{0, 1}));
  const auto before = m.counts();
  const auto message = [&](auto pred, auto gt) -> std::string {
    try {
      m.update(span(pred), span(gt), {}, 2);
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  };
  // The bad value is the last pixel: earlier ones must not have been counted.
  EXPECT_EQ(message(std::vector<std::uint8_t>{0, 1, 3}, std::vector<std::uint8_t>{0, 1, 1}),
            "prediction value 3 at pixel (0, 1) is not a class (0 to 2)");
  EXPECT_EQ(message(std::vector<std::int32_t>{0, -1}, std::vector<std::uint8_t>{0, 1}),
            "prediction value -1 at pixel (1, 0) is not a class (0 to 2)");
  EXPECT_EQ(message(std::vector<std::uint8_t>{0, 1}, std::vector<std::uint8_t>{0, 254}),
            "ground truth value 254 at pixel (1, 0) is not a class (0 to 2, ignored: 255)");
  EXPECT_EQ(message(std::vector<std::uint8_t>{0, 1}, std::vector<std::uint8_t>{0}),
            "prediction has 2 pixels but the ground truth 1");
  EXPECT_EQ(m.counts(), before);
  EXPECT_THROW(m.update(cv::Mat(2, 3, CV_8UC1, cv::Scalar(0)), cv::Mat(3, 2, CV_8UC1, cv::Scalar(0))), Error);
  EXPECT_THROW(m.update(cv::Mat(2, 2, CV_8UC3, cv::Scalar(0)), cv::Mat(2, 2, CV_8UC3, cv::Scalar(0))), Error);
  EXPECT_THROW(m.update(cv::Mat(2, 2, CV_32F, cv::Scalar(0)), cv::Mat(2, 2, CV_32F, cv::Scalar(0))), Error);
  EXPECT_EQ(m.counts(), before);
  EXPECT_THROW(ConfusionMatrix(0), Error);
  EXPECT_THROW(ConfusionMatrix(100000), Error);
}

}  // namespace
}  // namespace fishcam
