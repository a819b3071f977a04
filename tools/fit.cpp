// fishcam fit DATA.csv --to MODEL: a camera model from measured correspondences.
#include <charconv>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <tuple>

#include "cli_common.hpp"
#include "commands.hpp"
#include "correspondence_csv.hpp"

namespace fishcam::cli {

void register_fit(CLI::App& app) {
  auto* cmd = app.add_subcommand("fit",
                                 "Fit a camera model to measured correspondences (CSV: theta,rho or "
                                 "x,y,z,u,v) and report the pixel error");
  struct Options {
    std::string data, to;
    std::string imagersize;
    std::vector<double> center;
    double aspect = 1;
    bool fit_center = false, fit_aspect = false;
    CameraOutputOptions output;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("DATA", o->data, "CSV with a header: theta,rho | theta_deg,rho | x,y,z,u,v")->required();
  cmd->add_option("--to", o->to, "Model: " + fishcam::model_names_text())->required();
  cmd->add_option("--imagersize", o->imagersize, "Image size W,H (or WxH)")->required();
  cmd->add_option("--center", o->center, "Principal point cx,cy (px; the start when --fit-center)")
      ->delimiter(',')
      ->expected(2)
      ->required();
  cmd->add_option("--aspect", o->aspect, "a_y (a_x = 1)")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_flag("--fit-center", o->fit_center, "Also fit the principal point (x,y,z,u,v data only)");
  cmd->add_flag("--fit-aspect", o->fit_aspect, "Also fit a_y (x,y,z,u,v data only)");
  add_camera_output_options(cmd, &o->output);
  cmd->callback([o] {
    check_outputs({{o->output.out}}, {o->data}, o->output.force);
    const ModelSpec spec = parse_model_spec(o->to);
    const CameraFormat format = o->output.resolved_format();
    const CorrespondenceFile file = read_csv(o->data);
    CameraParameters start;
    std::tie(start.width, start.height) = parse_image_size(o->imagersize, "--imagersize");
    start.grid.principal_point = {o->center[0], o->center[1]};
    start.grid.pixel_scale = {1.0, o->aspect};
    std::vector<Correspondence> samples;
    if (file.kind == CorrespondenceFile::Kind::theta_rho) {
      if (o->fit_center || o->fit_aspect) throw Error("--fit-center/--fit-aspect need x,y,z,u,v data");
      for (const auto& r : file.rows) {
        const double theta = file.degrees ? r[0] * std::numbers::pi / 180 : r[0];
        if (!(theta >= 0 && theta <= std::numbers::pi) || r[1] < 0) {
          throw Error(o->data + ": theta must be in [0, pi] (or [0, 180] deg) and rho >= 0");
        }
        // Along +x: the pixel lies rho (a_x = 1) to the right of the centre.
        samples.push_back(
            {{std::sin(theta), 0, std::cos(theta)}, start.grid.principal_point + Eigen::Vector2d(r[1], 0)});
      }
    } else {
      for (const auto& r : file.rows) samples.push_back({{r[0], r[1], r[2]}, {r[3], r[4]}});
    }
    const CameraParameters fitted = fit_camera(samples, spec, start, {o->fit_center, o->fit_aspect});
    const ErrorReport report = reprojection_errors(Camera(fitted), samples);
    write_camera_file(fitted, o->output.out, format, o->output.force);
    if (o->output.json) {
      nlohmann::json j = nlohmann::json::parse(fit_report_json(fitted, report));
      j["out"] = o->output.out;
      j["format"] = to_string(format);
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("%s: %zu correspondences -> %s, wrote %s (%s)\n", o->data.c_str(), samples.size(), o->to.c_str(),
                o->output.out.c_str(), std::string(to_string(format)).c_str());
    print_fit_report(fitted, report, "correspondences");
  });
}

}  // namespace fishcam::cli
