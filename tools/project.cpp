// fishcam project CAMERA: camera-frame points "x y z" on stdin -> pixels "u v".
#include <cmath>
#include <cstdio>
#include <iostream>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/io/camera_io.hpp"
#include "line_input.hpp"

namespace fishcam::cli {

void register_project(CLI::App& app) {
  auto* cmd = app.add_subcommand("project",
                                 "Project camera-frame points: reads lines 'x y z' on stdin, writes 'u v' "
                                 "(%.17g) or 'nan nan' outside the valid domain");
  auto path = std::make_shared<std::string>();
  cmd->add_option("CAMERA", *path, "Camera file")->required();
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([path, inputs] {
    const Camera camera = inputs->read(*path);
    for_each_record<3>(std::cin, "three numbers 'x y z'", [&](const std::array<double, 3>& p) {
      Eigen::Vector2d pixel;
      if (camera.project({p[0], p[1], p[2]}, &pixel)) {
        std::printf("%.17g %.17g\n", pixel.x(), pixel.y());
      } else {
        std::printf("nan nan\n");
      }
    });
  });
}

}  // namespace fishcam::cli
