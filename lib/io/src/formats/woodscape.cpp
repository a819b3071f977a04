// WoodScape calibration JSON (valeoai/WoodScape), also as SynWoodScape writes it.
#include <cmath>

#include "format.hpp"

namespace fishcam::detail {

// WoodScape's files name k1..k16 at most (their poly_order field's range).
constexpr int kMaxWoodScapeOrder = 16;
namespace {

constexpr char kSynWoodScapeTranslation[] = "translation used in CARLA (CARLA reference)";

// "k1", "k2", ... (appended, not `"k" + to_string(i)`: GCC 12 warns falsely on that).
std::string coefficient_key(int i) {
  std::string key = "k";
  key += std::to_string(i);
  return key;
}

int score(const Content& c) {
  const auto* j = c.json();
  return j && j->is_object() && j->contains("intrinsic") ? 50 : 0;
}

std::vector<NamedCamera> read(const Content& c) {
  const DocNode& root = c.json_document();
  if (root.kind != DocNode::Kind::map) throw Error(c.source() + ": expected a JSON object at the top level");
  const DocFields top(root, c.source());
  const DocFields in = top.object("intrinsic");
  const std::string model = in.string("model");
  if (model != "radial_poly")
    in.fail("model", "unsupported WoodScape model " + quoted_for_message(model) + " (expected radial_poly)");
  const double poly_order = in.number("poly_order");
  if (!(poly_order >= 1 && poly_order <= kMaxWoodScapeOrder) || poly_order != std::floor(poly_order)) {
    in.fail("poly_order", "expected an integer in [1, " + std::to_string(kMaxWoodScapeOrder) + "]");
  }
  std::vector<double> k;
  for (int i = 1; i <= int(poly_order); ++i) k.push_back(in.number(coefficient_key(i)));
  NamedCamera out{"0", {}, {}};
  CameraParameters& p = out.camera;
  p.width = in.positive_integer("width");
  p.height = in.positive_integer("height");
  // WoodScape's offsets are from the image centre in a frame whose pixel centres
  // sit at half-integers; ours sit at integers, hence the -0.5.
  p.grid.principal_point = {p.width / 2.0 + in.number("cx_offset") - 0.5,
                            p.height / 2.0 + in.number("cy_offset") - 0.5};
  const double aspect = in.number("aspect_ratio");
  if (!(aspect > 0)) in.fail("aspect_ratio", "must be > 0");
  p.grid.pixel_scale = {1.0, aspect};
  p.model = Polynomial<double>(k);
  if (top.has("extrinsic")) {
    const DocFields ex = top.object("extrinsic");
    if (!ex.has("translation") && ex.has(kSynWoodScapeTranslation)) {
      // SynWoodScape: the translation is in CARLA's frame, which its files do not
      // document against WoodScape's vehicle frame: no pose rather than a wrong one.
      out.notes.push_back("extrinsic: SynWoodScape's '" + std::string(kSynWoodScapeTranslation) +
                          "' is in CARLA's frame; the camera is read without its pose");
    } else {
      p.pose = pose_from_json(ex, "quaternion");
    }
  }
  return {out};
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera)
  std::vector<double> k;
  if (const auto* poly = std::get_if<Polynomial<double>>(&p.model)) {
    k = poly->params();
  } else if (const auto* eq = std::get_if<Equidistant<double>>(&p.model)) {
    k = {eq->f()};
  } else {
    cannot_hold(p, CameraFormat::woodscape);
  }
  if (k.size() > size_t(kMaxWoodScapeOrder)) {
    throw Error("model: the WoodScape format holds polynomials up to order " + std::to_string(kMaxWoodScapeOrder) +
                ", not " + std::to_string(k.size()));
  }
  while (k.size() < 4) k.push_back(0.0);
  nlohmann::json in = {{"model", "radial_poly"},
                       {"poly_order", k.size()},
                       {"width", p.width},
                       {"height", p.height},
                       {"cx_offset", p.grid.principal_point.x() - p.width / 2.0 + 0.5},
                       {"cy_offset", p.grid.principal_point.y() - p.height / 2.0 + 0.5},
                       {"aspect_ratio", p.grid.pixel_scale.y()}};
  for (size_t i = 0; i < k.size(); ++i) in[coefficient_key(int(i) + 1)] = k[i];
  nlohmann::json root = {{"intrinsic", in}};
  if (p.pose) root["extrinsic"] = pose_to_json(*p.pose, "quaternion");
  return root.dump(2) + "\n";
}

}  // namespace

extern const FormatSpec woodscape_format{
    .id = CameraFormat::woodscape,
    .name = "woodscape",
    .description = "WoodScape / SynWoodScape calibration JSON",
    .extensions = {".json"},
    .models = {"polynomial", "equidistant"},
    .score = score,
    .read = read,
    .write = write,
};

}  // namespace fishcam::detail
