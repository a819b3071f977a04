// ROS camera_info YAML (camera_calibration_parsers), with or without a %YAML
// header. ROS's distortion_model "equidistant" is Kannala-Brandt (OpenCV's
// fisheye), not fishcam's equidistant model rho = f theta (docs/formats.md).
#include "format.hpp"

namespace fishcam::detail {
namespace {

int score(const Content& c) {
  const DocNode* root = c.yaml();
  return root && root->find("camera_matrix") && root->find("distortion_coefficients") ? 90 : 0;
}

std::vector<NamedCamera> read(const Content& c) {
  const DocNode& root = c.yaml_or_throw();
  const DocFields f(root, c.source());
  NamedCamera named{f.has("camera_name") ? f.string("camera_name") : "0", {}, {}};
  CameraParameters& p = named.camera;
  const auto k = f.matrix("camera_matrix", 9);
  if (k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1)
    f.fail("camera_matrix", "expected [fx 0 cx; 0 fy cy; 0 0 1]");
  set_focal(&p, k[0], k[4], [&](std::string_view problem) { f.fail("camera_matrix", problem); });
  p.grid.principal_point = {k[2], k[5]};
  const std::vector<double> d = f.numbers("distortion_coefficients", 0, 14);
  const std::string model = f.string("distortion_model");
  if (model == "equidistant" || model == "fisheye") {
    if (d.size() != 4) f.fail("distortion_coefficients", "equidistant (Kannala-Brandt) has 4 coefficients");
    p.model = KannalaBrandt<double>(k[0], d[0], d[1], d[2], d[3]);
  } else if (model == "plumb_bob" || model == "rational_polynomial") {
    set_radial_tangential(&p, d, k[0], [&](std::string_view problem) { f.fail("distortion_coefficients", problem); });
  } else {
    f.fail("distortion_model", "unsupported " + quoted_for_message(model) + " (expected equidistant or plumb_bob)");
  }
  p.width = f.positive_integer("image_width");
  p.height = f.positive_integer("image_height");
  return {named};
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera)
  const std::optional<RadialTangential> radtan = radial_tangential_of(p);
  const KannalaBrandtOrPinhole kb = radtan ? KannalaBrandtOrPinhole{} : kannala_brandt_or_pinhole(p, CameraFormat::ros);
  const double fx = radtan ? radtan->f : kb.fx, fy = radtan ? radtan->f * p.grid.pixel_scale.y() : kb.fy;
  const double cx = p.grid.principal_point.x(), cy = p.grid.principal_point.y();
  auto matrix = [](int rows, int cols, const std::vector<double>& data) {
    return "\n  rows: " + std::to_string(rows) + "\n  cols: " + std::to_string(cols) + "\n  data: " + yaml_list(data) +
           "\n";
  };
  std::string out;
  out += "image_width: " + std::to_string(p.width) + "\nimage_height: " + std::to_string(p.height) + "\n";
  out += "camera_name: camera\n";
  out += "camera_matrix:" + matrix(3, 3, {fx, 0, cx, 0, fy, cy, 0, 0, 1});
  out += std::string("distortion_model: ") +
         (!radtan            ? "equidistant"
          : radtan->rational ? "rational_polynomial"
                             : "plumb_bob") +
         "\n";
  out += "distortion_coefficients:" +
         (radtan ? matrix(1, int(radtan->d.size()), radtan->d) : matrix(1, 4, {kb.k[0], kb.k[1], kb.k[2], kb.k[3]}));
  out += "rectification_matrix:" + matrix(3, 3, {1, 0, 0, 0, 1, 0, 0, 0, 1});
  out += "projection_matrix:" + matrix(3, 4, {fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0});
  return out;
}

}  // namespace

extern const FormatSpec ros_format{
    .id = CameraFormat::ros,
    .name = "ros",
    .description = "ROS camera_info YAML",
    .extensions = {".yaml", ".yml"},
    .models = {"kannala-brandt", "equidistant", "pinhole", "opencv"},
    .distortions = {{"tangential", {"p1", "p2"}}},
    .score = score,
    .read = read,
    .write = write,
};

}  // namespace fishcam::detail
