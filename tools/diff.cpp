// fishcam diff CAMERA_A CAMERA_B: how differently two calibrations project.
#include <cmath>
#include <cstdio>
#include <numbers>

#include "cli_common.hpp"
#include "commands.hpp"

namespace fishcam::cli {

void register_diff(CLI::App& app) {
  auto* cmd = app.add_subcommand("diff", "Projection difference of two calibrations of one camera, after fitting the "
                                         "rotation between their frames (as mrcal.projection_diff)");
  struct Options {
    std::string a, b;
    int step = 8;
    bool no_rotation = false, json = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("CAMERA_A", o->a, "First camera file")->required();
  cmd->add_option("CAMERA_B", o->b, "Second camera file")->required();
  cmd->add_option("--step", o->step, "Compare every STEP-th pixel")->check(CLI::Range(1, 256))->capture_default_str();
  cmd->add_flag("--no-rotation", o->no_rotation, "Do not fit a rotation between the frames");
  cmd->add_flag("--json", o->json, "Print one JSON object");
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([o, inputs] {
    const Camera a = inputs->read(o->a), b = inputs->read(o->b);
    const ProjectionDiff diff = projection_diff(a, b, o->step, !o->no_rotation);
    const double angle_deg = Eigen::AngleAxisd(diff.rotation).angle() * 180 / std::numbers::pi;
    if (o->json) {
      const nlohmann::json j = {{"pixels", diff.pixels}, {"rms_px", diff.rms_px}, {"max_px", diff.max_px},
                                {"rotation_deg", angle_deg}};
      std::printf("%s\n", j.dump(2).c_str());
      return;
    }
    std::printf("%ld pixels: rms %.4g px, max %.4g px after a fitted rotation of %.4g deg\n", diff.pixels, diff.rms_px,
                diff.max_px, angle_deg);
  });
}

}  // namespace fishcam::cli
