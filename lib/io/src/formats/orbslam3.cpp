// ORB-SLAM3 settings YAML (cv::FileStorage style): Camera.type KannalaBrandt8 or
// PinHole, Camera.fx ... (Camera1. in the 1.0 settings), a second camera as Camera2.,
// the image size as Camera.width / Camera.height.
#include "format.hpp"

namespace fishcam::detail {
namespace {

int score(const Content& c) {
  const DocNode* root = c.yaml();
  if (!root) return 0;
  return root->find("Camera.type") || root->find("Camera.fx") || root->find("Camera1.fx") ? 100 : 0;
}

std::vector<NamedCamera> read(const Content& c) {
  const DocNode& root = c.yaml_or_throw();
  const DocFields f(root, c.source());
  std::string type = f.has("Camera.type") ? f.string("Camera.type") : "";
  if (type != "KannalaBrandt8" && type != "PinHole") {
    f.fail("Camera.type", type.empty()
                              ? "missing (expected KannalaBrandt8 or PinHole)"
                              : "unsupported " + quoted_for_message(type) + " (expected KannalaBrandt8 or PinHole)");
  }
  std::vector<NamedCamera> out;
  for (const char* prefix : {"Camera", "Camera1", "Camera2"}) {
    const std::string pre = std::string(prefix) + ".";
    if (!f.has(pre + "fx")) continue;
    NamedCamera named{prefix, {}, {}};
    CameraParameters& p = named.camera;
    const double fx = f.number(pre + "fx");
    set_focal(&p, fx, f.number(pre + "fy"), [&](std::string_view problem) { f.fail(pre + "fx", problem); });
    p.grid.principal_point = {f.number(pre + "cx"), f.number(pre + "cy")};
    if (type == "KannalaBrandt8") {
      p.model = KannalaBrandt<double>(fx, f.number(pre + "k1"), f.number(pre + "k2"), f.number(pre + "k3"),
                                      f.number(pre + "k4"));
    } else {
      std::vector<double> d = {f.number(pre + "k1"), f.number(pre + "k2"), f.number(pre + "p1"), f.number(pre + "p2")};
      if (f.has(pre + "k3")) d.push_back(f.number(pre + "k3"));
      set_radial_tangential(&p, d, fx, [&](std::string_view problem) { f.fail(pre + "k1", problem); });
    }
    if (f.has("Camera.width") || f.has("Camera.height")) {
      p.width = f.positive_integer("Camera.width");
      p.height = f.positive_integer("Camera.height");
    }
    out.push_back(std::move(named));
  }
  if (out.empty()) f.fail("Camera.fx", "missing (an ORB-SLAM3 camera has Camera.fx or Camera1.fx)");
  return out;
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera)
  const KannalaBrandtOrPinhole kb = kannala_brandt_or_pinhole(p, CameraFormat::orbslam3);
  const bool pinhole = kb.pinhole;
  std::string out = "%YAML:1.0\n\n";
  out += std::string("Camera.type: \"") + (pinhole ? "PinHole" : "KannalaBrandt8") + "\"\n\n";
  auto line = [&](const std::string& key, double v) { out += "Camera." + key + ": " + yaml_number(v) + "\n"; };
  line("fx", kb.fx), line("fy", kb.fy), line("cx", kb.cx), line("cy", kb.cy);
  if (pinhole) {
    line("k1", 0), line("k2", 0), line("p1", p.tangential_terms().p1), line("p2", p.tangential_terms().p2);
  } else {
    line("k1", kb.k[0]), line("k2", kb.k[1]), line("k3", kb.k[2]), line("k4", kb.k[3]);
  }
  out += "\nCamera.width: " + std::to_string(p.width) + "\nCamera.height: " + std::to_string(p.height) + "\n";
  return out;
}

}  // namespace

extern const FormatSpec orbslam3_format{
    .id = CameraFormat::orbslam3,
    .name = "orbslam3",
    .description = "ORB-SLAM3 settings YAML",
    .extensions = {".yaml", ".yml"},
    .models = {"kannala-brandt", "equidistant", "pinhole"},
    .distortions = {{"tangential", {"p1", "p2"}}},
    .score = score,
    .read = read,
    .write = write,
};

}  // namespace fishcam::detail
