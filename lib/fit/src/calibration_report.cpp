// The JSON reports of a calibration (calibration.hpp): what `fishcam calibrate --json`
// prints and `--poses` writes.
#include <nlohmann/json.hpp>

#include <cmath>
#include <numbers>

#include "fishcam/fit/calibration.hpp"

namespace fishcam {
namespace {

constexpr double kDegreesPerRadian = 180 / std::numbers::pi;

constexpr const char* kPoseConvention =
    "p_camera = R(quaternion) p_board + translation; board corner (i, j) at (i * spacing, j * spacing, z) on a "
    "chessboard, (c(i), c(j), z) with c(i) = floor(i / 2) (size + gap) + (i % 2) size on an AprilGrid, z = 0 or the "
    "board_warp's (x2 * 4u(1 - u) + y2 * 4v(1 - v), u = x / x(W - 1), v = y / y(H - 1)), in board order (rows of W "
    "corners)";

nlohmann::json poses_of(const CalibrationResult& result) {
  nlohmann::json poses = nlohmann::json::array();
  for (size_t i = 0; i < result.poses.size(); ++i) {
    const auto& q = result.poses[i].rotation;
    const auto& t = result.poses[i].translation;
    poses.push_back({{"image", result.used_images[i]},
                     {"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}},
                     {"translation", {t.x(), t.y(), t.z()}},
                     {"rms_px", result.per_image_rms_px[i]}});
  }
  return poses;
}

nlohmann::json outliers_of(const CalibrationResult& result) {
  nlohmann::json outliers = nlohmann::json::array();
  for (const auto& outlier : result.outliers) {
    outliers.push_back({{"image", outlier.filename}, {"corner", outlier.corner}, {"error_px", outlier.error_px}});
  }
  return outliers;
}

nlohmann::json sigma_of(double sigma) { return std::isnan(sigma) ? nlohmann::json(nullptr) : nlohmann::json(sigma); }

// {x2: {value, sigma}, y2: ...} in board units, or null: flat boards.
nlohmann::json board_warp_json(const CalibrationResult& result) {
  const auto& warp = result.board_warp;
  if (!warp) return nullptr;
  return {{"x2", {{"value", warp->x2}, {"sigma", sigma_of(result.board_warp_sigma.x2)}}},
          {"y2", {{"value", warp->y2}, {"sigma", sigma_of(result.board_warp_sigma.y2)}}}};
}

}  // namespace

std::string calibration_report_json(const CalibrationResult& result, const CameraParameters& written,
                                    const std::string& out) {
  const CalibrationRecord& record = *result.camera.calibration;
  nlohmann::json j = {
      {"model", model_name(result.camera.model)},
      {"plane_distortion", distortion_name(result.camera.distortion)},
      {"rms_px", result.rms_px},
      {"rms_per_coordinate_px", result.rms_px / std::sqrt(2.0)},
      {"noise_px", result.noise_px},
      {"corners", result.observations},
      {"images", result.used_images.size()},
      {"outliers", outliers_of(result)},
      {"undetermined", result.undetermined},
      {"observed_theta_max_deg", record.theta_max * kDegreesPerRadian},
      {"theta_limit_deg", written.theta_limit ? nlohmann::json(*written.theta_limit * kDegreesPerRadian) : nullptr},
      {"theta_limit_by_azimuth_deg", nullptr},
      {"poses", poses_of(result)},
      {"pose_convention", kPoseConvention},
      {"warnings", result.warnings},
      {"out", out}};
  if (written.theta_limit_by_azimuth) {
    for (double a : *written.theta_limit_by_azimuth) j["theta_limit_by_azimuth_deg"].push_back(a * kDegreesPerRadian);
  }
  j["board_warp"] = board_warp_json(result);
  for (size_t i = 0; i < result.parameters.size(); ++i) {
    const double sigma = result.sigmas[i];
    j["parameters"][result.parameter_names[i]] = {
        {"value", result.parameters[i]}, {"sigma", sigma_of(sigma)}, {"determined", !std::isnan(sigma)}};
  }
  for (size_t i = 0; i < result.used_images.size(); ++i) {
    j["per_image_rms_px"][result.used_images[i]] = result.per_image_rms_px[i];
  }
  return j.dump(2);
}

std::string rig_calibration_report_json(const RigCalibrationResult& rig, const std::vector<std::string>& corners_files,
                                        const std::string& out) {
  nlohmann::json report = {{"rms_px", rig.rms_px},
                           {"rms_per_coordinate_px", rig.rms_px / std::sqrt(2.0)},
                           {"instants", rig.instants},
                           {"board_warp", rig.cameras.empty() ? nullptr : board_warp_json(rig.cameras[0])},
                           {"warnings", rig.warnings},
                           {"out", out},
                           {"pose_convention",
                            "camera -> camera 0: p_camera0 = R(quaternion) p_camera + translation; "
                            "board poses as for one camera, in each camera's frame"}};
  for (size_t k = 0; k < rig.cameras.size(); ++k) {
    const CalibrationResult& r = rig.cameras[k];
    const Pose& pose = *r.camera.pose;
    nlohmann::json camera = {
        {"corners_file", k < corners_files.size() ? corners_files[k] : ""},
        {"model", model_name(r.camera.model)},
        {"intrinsics", k < rig.fixed_intrinsics.size() && rig.fixed_intrinsics[k] ? "fixed" : "solved"},
        {"rms_px", r.rms_px},
        {"corners", r.observations},
        {"images", r.used_images.size()},
        {"outliers", outliers_of(r)},
        {"undetermined", r.undetermined},
        {"pose",
         {{"quaternion_xyzw", {pose.rotation.x(), pose.rotation.y(), pose.rotation.z(), pose.rotation.w()}},
          {"translation", {pose.translation.x(), pose.translation.y(), pose.translation.z()}},
          {"rotation_sigma_deg", rig.rotation_sigma_rad[k] * kDegreesPerRadian},
          {"translation_sigma", rig.translation_sigma[k]}}}};
    for (size_t i = 0; i < r.parameters.size(); ++i) {
      camera["parameters"][r.parameter_names[i]] = {{"value", r.parameters[i]}, {"sigma", sigma_of(r.sigmas[i])}};
    }
    report["cameras"].push_back(camera);
  }
  return report.dump(2);
}

std::string calibration_poses_json(const CalibrationResult& result) {
  return nlohmann::json({{"convention", kPoseConvention}, {"poses", poses_of(result)}}).dump(2);
}

std::string rig_calibration_poses_json(const RigCalibrationResult& rig) {
  nlohmann::json cameras = nlohmann::json::array();
  for (size_t k = 0; k < rig.cameras.size(); ++k)
    cameras.push_back({{"camera", k}, {"poses", poses_of(rig.cameras[k])}});
  return nlohmann::json({{"convention", kPoseConvention}, {"cameras", cameras}}).dump(2);
}

}  // namespace fishcam
