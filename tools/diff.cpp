// fishcam diff CAMERA_A CAMERA_B: how differently two calibrations project, where
// the calibrations saw corners (mrcal's projection_diff).
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/io/corners.hpp"

namespace fishcam::cli {

namespace {

// Where `fishcam diff` compares (options->region), and its description: the convex
// hull of the corners in `corners` (held in *hull), else the angles a calibration
// record observed, else every pixel valid in both cameras (refused for --region data).
std::string data_region(const std::string& region_option, const std::string& corners, const std::string& board,
                        const Camera& a, const Camera& b, std::vector<cv::Point2f>* hull,
                        ProjectionDiffOptions* options) {
  const auto& record_a = a.parameters().calibration;
  const auto& record_b = b.parameters().calibration;
  if (region_option == "all") return "every pixel valid in both cameras";
  if (!corners.empty()) {
    std::vector<cv::Point2f> points;
    for (const auto& observation : read_corners(corners, parse_board(board, 1.0))) {
      for (const auto& c : observation.corners) points.emplace_back(float(c.x()), float(c.y()));
    }
    if (points.size() < 3) throw Error(corners + ": fewer than 3 corners: no region");
    cv::convexHull(points, *hull);
    options->region = [hull](const Eigen::Vector2d& pixel, const Eigen::Vector3d&) {
      return cv::pointPolygonTest(*hull, cv::Point2f(float(pixel.x()), float(pixel.y())), false) >= 0;
    };
    return "the convex hull of the corners in " + corners;
  }
  if (record_a || record_b) {
    const CalibrationRecord record = record_a ? *record_a : *record_b;
    options->region = [record](const Eigen::Vector2d&, const Eigen::Vector3d& ray) { return record.observed(ray); };
    return std::string("the angles the calibration of ") + (record_a ? "CAMERA_A" : "CAMERA_B") +
           " observed (its calibration record)";
  }
  if (region_option == "data") {
    throw Error(
        "--region data: neither camera carries a calibration record (fishcam calibrate writes one); pass "
        "--corners FILE --board WxH");
  }
  return "every pixel valid in both cameras";
}

}  // namespace

void register_diff(CLI::App& app) {
  auto* cmd = app.add_subcommand("diff",
                                 "Projection difference of two calibrations of one camera, after fitting the "
                                 "rotation between their frames (as mrcal.projection_diff)");
  struct Options {
    std::string a, b, region = "auto", weights = "auto", corners, board;
    int step = 8;
    bool no_rotation = false, json = false, resize = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("CAMERA_A", o->a, "First camera file")->required();
  cmd->add_option("CAMERA_B", o->b, "Second camera file")->required();
  cmd->add_option("--step", o->step, "Compare every STEP-th pixel")->check(CLI::Range(1, 256))->capture_default_str();
  cmd->add_option("--region", o->region,
                  "data: only where the calibration saw corners (the hull of --corners, else A's or B's observed "
                  "angles); all: every pixel valid in both; auto: data where known, else all")
      ->check(CLI::IsMember({"auto", "data", "all"}))
      ->capture_default_str();
  cmd->add_option("--corners", o->corners,
                  "Corners file (mrcal's vnlog) whose corners' convex hull is the data region");
  cmd->add_option("--board", o->board, "Inner corners WxH of the --corners board");
  cmd->add_option("--weights", o->weights,
                  "uncertainty: weigh the rotation fit by 1 / (sigma_A^2 + sigma_B^2) (both cameras need a "
                  "calibration covariance); none; auto: uncertainty when both carry one")
      ->check(CLI::IsMember({"auto", "uncertainty", "none"}))
      ->capture_default_str();
  cmd->add_flag("--no-rotation", o->no_rotation, "Do not fit a rotation between the frames");
  cmd->add_flag("--resize", o->resize,
                "Compare CAMERA_B resized to CAMERA_A's image size (the same lens, its pixels scaled) when the sizes "
                "differ (refused otherwise)");
  cmd->add_flag("--json", o->json, "Print one JSON object");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, inputs] {
    if (o->corners.empty() != o->board.empty()) throw Error("--corners and --board go together");
    if (!o->corners.empty() && o->region == "all")
      throw Error("--corners defines a data region: not with --region all");
    const Camera a = inputs->read(o->a);
    Camera b = inputs->read(o->b);
    // Pixels of two sizes are not the same pixels: comparing them measures the resize.
    if (a.width() != b.width() || a.height() != b.height()) {
      if (!o->resize) {
        throw Error("CAMERA_A is " + std::to_string(a.width()) + "x" + std::to_string(a.height()) + ", CAMERA_B " +
                    std::to_string(b.width()) + "x" + std::to_string(b.height()) +
                    ": cameras of different image sizes are not compared (--resize compares CAMERA_B resized to "
                    "CAMERA_A's size)");
      }
      b = Camera(resized(b.parameters(), a.width(), a.height()));
    }
    const auto& record_a = a.parameters().calibration;
    const auto& record_b = b.parameters().calibration;
    ProjectionDiffOptions options;
    options.step = o->step, options.fit_rotation = !o->no_rotation;
    std::vector<cv::Point2f> hull;
    const std::string region = data_region(o->region, o->corners, o->board, a, b, &hull, &options);
    const bool both_uncertain = record_a && record_b && record_a->covariance.size() && record_b->covariance.size();
    if (o->weights == "uncertainty" && !both_uncertain) {
      throw Error(
          "--weights uncertainty: both cameras need a calibration covariance (fishcam JSON written by "
          "fishcam calibrate)");
    }
    options.weigh_by_uncertainty = o->weights == "uncertainty" || (o->weights == "auto" && both_uncertain);
    const ProjectionDiff diff = projection_diff(a, b, options);
    const double angle_deg = Eigen::AngleAxisd(diff.rotation).angle() * 180 / std::numbers::pi;
    const std::string weights = options.weigh_by_uncertainty ? "1 / (sigma_A^2 + sigma_B^2)" : "none";
    if (o->json) {
      const nlohmann::json j = {{"pixels", diff.pixels},     {"rms_px", diff.rms_px}, {"max_px", diff.max_px},
                                {"rotation_deg", angle_deg}, {"region", region},      {"weights", weights}};
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("%ld pixels: rms %.4g px, max %.4g px after a fitted rotation of %.4g deg\n", diff.pixels, diff.rms_px,
                diff.max_px, angle_deg);
    std::printf("  region: %s; rotation fit weights: %s\n", region.c_str(), weights.c_str());
  });
}

}  // namespace fishcam::cli
