// fishcam's own JSON: every model of the registry, as it is.
#include <cmath>
#include <numbers>

#include "format.hpp"

namespace fishcam::detail {
namespace {

constexpr double kDeg = 180 / std::numbers::pi;

int score(const Content& c) {
  const auto* j = c.json();
  return j && j->is_object() && j->contains("fishcam_camera") ? 100 : 0;
}

std::vector<NamedCamera> read(const Content& c) {
  const DocFields f(c.json_document(), c.source());
  const double version = f.number("fishcam_camera");
  if (version != 1) f.fail("fishcam_camera", "unsupported format version (this build reads version 1)");
  CameraParameters p;
  p.width = f.positive_integer("width");
  p.height = f.positive_integer("height");
  const auto pp = f.numbers("principal_point", 2, 2);
  const auto scale = f.numbers("pixel_scale", 2, 2);
  p.principal_point = {pp[0], pp[1]};
  p.pixel_scale = {scale[0], scale[1]};
  const std::string name = f.string("model");
  const auto params = f.numbers("parameters", 1, 64);
  try {
    p.model = make_model(name, params);
  } catch (const Error& e) {
    f.fail("model", e.what());
  }
  if (f.has("theta_limit_deg")) p.theta_limit = f.number("theta_limit_deg") / kDeg;
  if (f.has("pose")) p.pose = pose_from_json(f.object("pose"), "quaternion_xyzw");
  return {{"0", p, {}}};
}

std::string write(const CameraParameters& p) {
  nlohmann::json root = {{"fishcam_camera", 1},
                         {"width", p.width},
                         {"height", p.height},
                         {"principal_point", {p.principal_point.x(), p.principal_point.y()}},
                         {"pixel_scale", {p.pixel_scale.x(), p.pixel_scale.y()}},
                         {"model", model_name(p.model)},
                         {"parameters", model_params(p.model)}};
  if (p.theta_limit) root["theta_limit_deg"] = *p.theta_limit * kDeg;
  if (p.pose) root["pose"] = pose_to_json(*p.pose, "quaternion_xyzw");
  return root.dump(2) + "\n";
}

}  // namespace

extern const FormatSpec fishcam_format{CameraFormat::fishcam, "fishcam", "fishcam camera JSON", {".json"},
                                       {}, score, read, write, true, true};

}  // namespace fishcam::detail
