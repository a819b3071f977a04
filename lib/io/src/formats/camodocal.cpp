// camodocal YAML (as VINS-Mono / VINS-Fusion keep it): KANNALA_BRANDT, MEI and
// PINHOLE (k1, k2, p1, p2), tangential terms included.
#include "format.hpp"

namespace fishcam::detail {
namespace {

int score(const Content& c) {
  const DocNode* root = c.yaml();
  return root && root->find("model_type") ? 100 : 0;
}

std::vector<NamedCamera> read(const Content& c) {
  const DocNode& root = c.yaml_or_throw();
  const DocFields f(root, c.source());
  const std::string type = f.string("model_type");
  NamedCamera named{f.has("camera_name") ? f.string("camera_name") : "0", {}, {}};
  CameraParameters& p = named.camera;
  if (type == "KANNALA_BRANDT") {
    // theta_d = theta + k2 theta^3 + k3 theta^5 + k4 theta^7 + k5 theta^9; u = mu theta_d cos(phi) + u0.
    const DocFields k = f.object("projection_parameters");
    const double mu = k.number("mu");
    set_focal(&p, mu, k.number("mv"), [&](std::string_view problem) { k.fail("mu", problem); });
    p.grid.principal_point = {k.number("u0"), k.number("v0")};
    p.model = KannalaBrandt<double>(mu, k.number("k2"), k.number("k3"), k.number("k4"), k.number("k5"));
  } else if (type == "MEI") {
    const DocFields k = f.object("projection_parameters");
    const DocFields d = f.object("distortion_parameters");
    const double gamma1 = k.number("gamma1");
    set_focal(&p, gamma1, k.number("gamma2"), [&](std::string_view problem) { k.fail("gamma1", problem); });
    p.grid.principal_point = {k.number("u0"), k.number("v0")};
    p.model = Mei<double>(gamma1, f.object("mirror_parameters").number("xi"), d.number("k1"), d.number("k2"));
    p.distortion = TangentialDistortion{{d.number("p1"), d.number("p2"), {}}};
  } else if (type == "PINHOLE") {
    const DocFields k = f.object("projection_parameters");
    const DocFields d = f.object("distortion_parameters");
    const double fx = k.number("fx");
    set_focal(&p, fx, k.number("fy"), [&](std::string_view problem) { k.fail("fx", problem); });
    p.grid.principal_point = {k.number("cx"), k.number("cy")};
    set_radial_tangential(&p, {d.number("k1"), d.number("k2"), d.number("p1"), d.number("p2")}, fx,
                          [&](std::string_view problem) { d.fail("k1", problem); });
  } else if (type == "SCARAMUZZA") {
    f.fail("model_type",
           "SCARAMUZZA: camodocal's projection and unprojection disagree for an affine c, d, e other "
           "than the identity, and its forks differ in inv_poly's length; give fishcam OCamCalib's "
           "calib_results.txt (format ocamcalib)");
  } else {
    f.fail("model_type", "unsupported " + quoted_for_message(type) + " (expected KANNALA_BRANDT, MEI or PINHOLE)");
  }
  p.width = f.positive_integer("image_width");
  p.height = f.positive_integer("image_height");
  return {named};
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera)
  const double p1 = p.tangential_terms().p1, p2 = p.tangential_terms().p2;
  const double ay = p.grid.pixel_scale.y(), cx = p.grid.principal_point.x(), cy = p.grid.principal_point.y();
  std::string out = "%YAML:1.0\n---\n";
  const KannalaBrandtLike kb = kannala_brandt_of(p);
  auto header = [&](const char* type) {
    out += std::string("model_type: ") + type + "\ncamera_name: camera\n";
    out += "image_width: " + std::to_string(p.width) + "\nimage_height: " + std::to_string(p.height) + "\n";
  };
  auto line = [&](const char* key, double v) { out += std::string("   ") + key + ": " + yaml_number(v) + "\n"; };
  if (kb.ok) {
    header("KANNALA_BRANDT");
    out += "projection_parameters:\n";
    line("k2", kb.k[0]), line("k3", kb.k[1]), line("k4", kb.k[2]), line("k5", kb.k[3]);
    line("mu", kb.f), line("mv", kb.f * ay), line("u0", cx), line("v0", cy);
  } else if (std::holds_alternative<Mei<double>>(p.model) || std::holds_alternative<Unified<double>>(p.model)) {
    const auto q = model_params(p.model);  // f, xi[, k1, k2]
    header("MEI");
    out += "mirror_parameters:\n";
    line("xi", q[1]);
    out += "distortion_parameters:\n";
    line("k1", q.size() > 2 ? q[2] : 0.0), line("k2", q.size() > 2 ? q[3] : 0.0), line("p1", p1), line("p2", p2);
    out += "projection_parameters:\n";
    line("gamma1", q[0]), line("gamma2", q[0] * ay), line("u0", cx), line("v0", cy);
  } else if (const auto* m = std::get_if<Pinhole<double>>(&p.model)) {
    header("PINHOLE");
    out += "distortion_parameters:\n";
    line("k1", 0), line("k2", 0), line("p1", p1), line("p2", p2);
    out += "projection_parameters:\n";
    line("fx", m->f()), line("fy", m->f() * ay), line("cx", cx), line("cy", cy);
  } else {
    cannot_hold(p, CameraFormat::camodocal);
  }
  return out;
}

}  // namespace

extern const FormatSpec camodocal_format{
    .id = CameraFormat::camodocal,
    .name = "camodocal",
    .description = "camodocal YAML",
    .extensions = {".yaml", ".yml"},
    .models = {"kannala-brandt", "equidistant", "mei", "unified", "pinhole"},
    .distortions = {{"tangential", {"p1", "p2"}}},
    .score = score,
    .read = read,
    .write = write,
};

}  // namespace fishcam::detail
