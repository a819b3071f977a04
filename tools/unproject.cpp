// fishcam unproject CAMERA: pixels "u v" on stdin -> unit rays "x y z".
#include <cstdio>
#include <iostream>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/io/camera_io.hpp"
#include "line_input.hpp"

namespace fishcam::cli {

void register_unproject(CLI::App& app) {
  auto* cmd = app.add_subcommand("unproject",
                                 "Unproject pixels: reads lines 'u v' on stdin, writes the unit ray 'x y z' "
                                 "(%.17g) or 'nan nan nan' outside the valid domain");
  auto path = std::make_shared<std::string>();
  cmd->add_option("CAMERA", *path, "Camera file")->required();
  const auto inputs = add_camera_input_options(cmd);
  cmd->callback([path, inputs] {
    const Camera camera = inputs->read(*path);
    for_each_record<2>(std::cin, "two numbers 'u v'", [&](const std::array<double, 2>& q) {
      Eigen::Vector3d ray;
      if (camera.unproject({q[0], q[1]}, &ray)) {
        std::printf("%.17g %.17g %.17g\n", ray.x(), ray.y(), ray.z());
      } else {
        std::printf("nan nan nan\n");
      }
    });
  });
}

}  // namespace fishcam::cli
