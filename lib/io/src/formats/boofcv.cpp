// BoofCV's intrinsic calibration YAML (CalibrationIO): `model` with a `pinhole` map
// (fx, fy, cx, cy, width, height, skew: the pixel skew xy = skew / fx) and, for
// omnidirectional_universal (Mei's model) and pinhole_radial_tangential, `radial_tangential` {radial: [...], t1, t2}
// and `mirror_offset` (xi).
#include "format.hpp"

namespace fishcam::detail {
namespace {

constexpr std::string_view kModels[] = {"pinhole", "pinhole_radial_tangential", "omnidirectional_universal",
                                        "kannala_brandt"};

int score(const Content& c) {
  const DocNode* root = c.yaml();
  if (!root) return 0;
  const DocNode* model = root->find("model");
  const DocNode* pinhole = root->find("pinhole");
  if (!model || model->kind != DocNode::Kind::scalar || !pinhole || pinhole->kind != DocNode::Kind::map) return 0;
  return std::find(std::begin(kModels), std::end(kModels), model->scalar) != std::end(kModels) ? 100 : 0;
}

std::vector<NamedCamera> read(const Content& c) {
  const DocFields f(c.yaml_or_throw(), c.source());
  const std::string model = f.string("model");
  const DocFields k = f.object("pinhole");
  NamedCamera named{"0", {}, {}};
  CameraParameters& p = named.camera;
  const double fx = k.number("fx");
  set_focal(&p, fx, k.number("fy"), [&](std::string_view problem) { k.fail("fx", problem); });
  // u = fx x + skew y + cx: the pixel skew xy = skew / fx (CameraParameters::skew).
  p.grid.skew.xy = k.number("skew") / fx;
  p.grid.principal_point = {k.number("cx"), k.number("cy")};
  p.width = k.positive_integer("width");
  p.height = k.positive_integer("height");
  // radial k1, k2, ... on r^2 of the normalized point; t1, t2 tangential.
  const auto distortion = [&](size_t max_radial) {
    const DocFields d = f.object("radial_tangential");
    std::vector<double> radial = d.has("radial") ? d.numbers("radial", 0, 64) : std::vector<double>{};
    if (radial.size() > max_radial) {
      d.fail("radial", "expected at most " + std::to_string(max_radial) + " coefficients for " + model + ", got " +
                           std::to_string(radial.size()));
    }
    // BoofCV adds t1, t2 to the radially distorted point (UniOmniStoP), not to the
    // undistorted one as OpenCV, Mei and fishcam do: a different model.
    if ((d.has("t1") && d.number("t1") != 0) || (d.has("t2") && d.number("t2") != 0)) {
      d.fail("t1",
             "BoofCV's tangential terms act on the radially distorted point, unlike OpenCV's and Mei's; fishcam "
             "reads BoofCV files with t1 = t2 = 0");
    }
    radial.resize(max_radial, 0.0);
    return radial;
  };
  if (model == "pinhole") {
    p.model = Pinhole<double>(fx);
  } else if (model == "omnidirectional_universal") {
    const std::vector<double> radial = distortion(2);
    p.model = Mei<double>(fx, f.number("mirror_offset"), radial[0], radial[1]);
  } else if (model == "pinhole_radial_tangential") {
    const std::vector<double> radial = distortion(3);
    set_radial_tangential(&p, {radial[0], radial[1], 0, 0, radial[2]}, fx,
                          [&](std::string_view problem) { f.fail("radial_tangential", problem); });
  } else {
    f.fail("model", "BoofCV's " + quoted_for_message(model) +
                        " (with its asymmetric terms) is not a model fishcam reads (it reads pinhole, "
                        "pinhole_radial_tangential and omnidirectional_universal)");
  }
  return {named};
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera)
  if (p.grid.skew.yx != 0) throw Error("skew: BoofCV's skew is one number (xy, K's [0, 1] entry / fx): yx must be 0");
  std::string out = "# BoofCV intrinsic calibration (CalibrationIO), written by fishcam\n";
  const std::vector<double> q = model_params(p.model);
  const bool omni = std::holds_alternative<Mei<double>>(p.model) || std::holds_alternative<Unified<double>>(p.model);
  if (!omni && !std::holds_alternative<Pinhole<double>>(p.model)) cannot_hold(p, CameraFormat::boofcv);
  out += std::string("model: ") + (omni ? "omnidirectional_universal" : "pinhole") + "\nversion: 0\npinhole:\n";
  const auto line = [&](const char* key, double v) { out += std::string("  ") + key + ": " + yaml_number(v) + "\n"; };
  line("fx", q[0]), line("fy", q[0] * p.grid.pixel_scale.y()), line("cx", p.grid.principal_point.x()),
      line("cy", p.grid.principal_point.y()), line("skew", p.grid.skew.xy * q[0]);
  out += "  width: " + std::to_string(p.width) + "\n  height: " + std::to_string(p.height) + "\n";
  if (omni) {
    out += "mirror_offset: " + yaml_number(q[1]) + "\nradial_tangential:\n";
    out +=
        "  radial: " + yaml_list({q.size() > 2 ? q[2] : 0.0, q.size() > 2 ? q[3] : 0.0}) + "\n  t1: 0.0\n  t2: 0.0\n";
  }
  return out;
}

}  // namespace

extern const FormatSpec boofcv_format{
    .id = CameraFormat::boofcv,
    .name = "boofcv",
    .description = "BoofCV calibration YAML",
    .extensions = {".yaml", ".yml"},
    .models = {"mei", "unified", "pinhole"},
    .score = score,
    .read = read,
    .write = write,
    .holds = {.skew = true},
};

}  // namespace fishcam::detail
