// fishcam info CAMERA [--json]: what a calibration says and where it is valid.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <numbers>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/io/camera_io.hpp"

namespace fishcam::cli {
namespace {

void print_text(const nlohmann::json& j) {
  std::printf("format            %s\n", j["format"].get<std::string>().c_str());
  std::printf("model             %s\n", j["model"].get<std::string>().c_str());
  std::printf("parameters       ");
  for (double v : j["parameters"]) std::printf(" %.10g", v);
  if (const auto& s = j["mrcal_lens"]; !s.is_null()) {
    std::printf("\nmrcal lens        %s (%zu values, on the %s plane, evaluated by libmrcal; not radially symmetric)",
                s["lensmodel"].get<std::string>().c_str(), s["values"].get<size_t>(),
                s["base_model"].get<std::string>().c_str());
  }
  if (const auto& t = j["tangential"]; !t.is_null()) {
    std::printf("\ntangential        p1 %.10g, p2 %.10g, s1..s4 %.10g %.10g %.10g %.10g (not radially symmetric)",
                t["p1"].get<double>(), t["p2"].get<double>(), t["s1"].get<double>(), t["s2"].get<double>(),
                t["s3"].get<double>(), t["s4"].get<double>());
  }
  if (const auto& k = j["skew"]; !k.is_null()) {
    std::printf("\nskew              xy %.10g, yx %.10g (pixel grid [1 xy; yx 1]; not radially symmetric)",
                k["xy"].get<double>(), k["yx"].get<double>());
  }
  std::printf("\nimage             %d x %d\n", j["width"].get<int>(), j["height"].get<int>());
  std::printf("principal point   (%.6f, %.6f)\n", j["cx"].get<double>(), j["cy"].get<double>());
  std::printf("pixel scale       (%.10g, %.10g)\n", j["pixel_scale"][0].get<double>(),
              j["pixel_scale"][1].get<double>());
  std::printf("theta_max         %.6f deg%s (limited by %s)\n", j["theta_max_deg"].get<double>(),
              j["theta_max_closed"].get<bool>() ? "" : ", exclusive",
              j["theta_max_limited_by"].get<std::string>().c_str());
  if (const auto& limits = j["theta_limit_by_azimuth_deg"]; !limits.is_null()) {
    const auto [low, high] = std::minmax_element(limits.begin(), limits.end());
    std::printf(
        "theta limit       per azimuth, %.3f to %.3f deg (24 sectors of 15 deg: unprojection refuses past it)\n",
        low->get<double>(), high->get<double>());
  }
  const char* radial_part =
      j["tangential"].is_null() && j["mrcal_lens"].is_null() && j["skew"].is_null() ? "" : " (radial part)";
  if (j["rho_max_px"].is_null()) {
    std::printf("rho_max           unbounded%s\n", radial_part);
  } else {
    std::printf("rho_max           %.6f px%s\n", j["rho_max_px"].get<double>(), radial_part);
  }
  const auto& fov = j["fov_deg"];
  std::printf("field of view     %.3f deg horizontal, %.3f vertical, %.3f diagonal\n", fov["horizontal"].get<double>(),
              fov["vertical"].get<double>(), fov["diagonal"].get<double>());
  const auto& table = j["inverse_table"];
  if (!j["tangential"].is_null() || !j["mrcal_lens"].is_null()) {
    std::printf("unprojection      2-D Newton on the distortion map, checked to reproject within 1e-7 px\n");
  } else if (table["cells"].get<int>() > 0) {
    std::printf("inverse table     %d cells, worst error %.3g px, %d cells use the robust solver\n",
                table["cells"].get<int>(), table["worst_error_px"].get<double>(), table["fallback_cells"].get<int>());
  } else if (table["closed_form"].get<bool>()) {
    std::printf("inverse table     none (closed-form inverse)\n");
  } else {
    std::printf("inverse table     none (open domain: the robust solver per point)\n");
  }
  if (const auto& observed = j["observed"]; observed.is_null()) {
    std::printf("observed angles   unknown (no calibration record: only fishcam calibrate writes one)\n");
  } else {
    const auto axis = [](const nlohmann::json& v) {
      return v.is_null() ? std::string("-") : std::to_string(int(std::lround(v.get<double>())));
    };
    std::printf("observed angles   theta up to %.3f deg; the corners span %s deg horizontally, %s deg vertically%s\n",
                observed["theta_max_deg"].get<double>(), axis(observed["fov_deg"]["horizontal"]).c_str(),
                axis(observed["fov_deg"]["vertical"]).c_str(),
                observed["has_covariance"].get<bool>() ? " (projection uncertainty: fishcam uncertainty)" : "");
    for (const auto& text : observed["extrapolated"]) {
      std::printf("  extrapolated:   %s\n", text.get<std::string>().c_str());
    }
  }
  if (j.contains("pose")) {
    const auto& q = j["pose"]["quaternion_xyzw"];
    const auto& t = j["pose"]["translation"];
    std::printf("pose (cam->ref)   q_xyzw [%.10g, %.10g, %.10g, %.10g], t [%.10g, %.10g, %.10g]\n", q[0].get<double>(),
                q[1].get<double>(), q[2].get<double>(), q[3].get<double>(), t[0].get<double>(), t[1].get<double>(),
                t[2].get<double>());
  }
}

}  // namespace

void register_info(CLI::App& app) {
  auto* cmd = app.add_subcommand("info", "Print a camera's model, parameters, valid domain and field of view");
  auto path = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  cmd->add_option("CAMERA", *path, "Camera file (" + camera_format_names() + ")")->required();
  cmd->add_flag("--json", *json, "Print one JSON object");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([path, json, inputs] {
    CameraFileInfo info;
    const Camera camera = inputs->read(*path, &info);
    nlohmann::json j = nlohmann::json::parse(camera_info_json(camera, info.format));
    // JSON holds UTF-8 only: a name that is not (a key from a hostile file) is given escaped.
    const std::string name = is_valid_utf8(info.camera_name) ? info.camera_name : quoted_for_message(info.camera_name);
    j["camera"] = {{"name", name}, {"index", info.camera_index}, {"count", info.camera_count}};
    if (*json) {
      std::printf("%s\n", j.dump(2).c_str());
    } else {
      print_text(j);
    }
  });
}

}  // namespace fishcam::cli
