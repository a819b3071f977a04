// OpenCV FileStorage YAML/XML: fisheye (Kannala-Brandt) K/D as fishcam writes
// them, and the key names other tools use (cameraMatrix/distCoeffs, M/D,
// width/height). Read with yaml-cpp / pugixml, never cv::FileStorage (its parser
// crashes on bad input); written with cv::FileStorage.
#include <opencv2/core.hpp>

#include "format.hpp"

namespace fishcam::detail {
namespace {

struct Keys {
  const char* matrix;
  const char* distortion;
};
constexpr Keys kKeys[] = {{"K", "D"}, {"cameraMatrix", "distCoeffs"}, {"M", "D"}};

const Keys* keys_of(const DocNode& root) {
  for (const Keys& k : kKeys) {
    if (root.find(k.matrix) && root.find(k.distortion)) return &k;
  }
  return nullptr;
}

int score(const Content& c) {
  const DocNode* root = c.yaml();
  if (!root || root->kind != DocNode::Kind::map) return 0;
  if (keys_of(*root)) return 80;
  return root->find("rvec_cam_ref") || root->find("image_width") ? 10 : 0;  // looks like ours, keys missing
}

std::vector<NamedCamera> read(const Content& c) {
  const DocNode& root = c.yaml_or_throw();
  if (root.kind != DocNode::Kind::map) throw Error(c.source() + ": not an OpenCV YAML/XML file (no top-level map)");
  const DocFields f(root, c.source());
  const Keys* keys = keys_of(root);
  if (!keys) {
    f.fail(root.find("K") ? "D" : "K",
           "missing (an OpenCV camera has K and D, or cameraMatrix and distCoeffs, or M and D)");
  }
  const auto k = f.matrix(keys->matrix, 9);
  const std::vector<double> d = f.numbers(keys->distortion, 4, 14);
  if (k[1] != 0) f.fail(keys->matrix, "skew (K[0][1]) is not supported");
  if (k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1) f.fail(keys->matrix, "expected [fx 0 cx; 0 fy cy; 0 0 1]");
  NamedCamera out{"0", {}, {}};
  CameraParameters& p = out.camera;
  set_focal(&p, k[0], k[4], [&](std::string_view problem) { f.fail(keys->matrix, problem); });
  p.grid.principal_point = {k[2], k[5]};
  const std::optional<std::string> said = c.options() ? c.options()->distortion_model : std::nullopt;
  if (!f.has("distortion_model") && !said) {
    f.fail("distortion_model", "missing: " + std::to_string(d.size()) +
                                   " distortion coefficients could be fisheye (Kannala-Brandt) or radial-tangential; "
                                   "say which (distortion_model fisheye or plumb_bob)");
  }
  const std::string model = f.has("distortion_model") ? f.string("distortion_model") : *said;
  if (said && *said != model)
    f.fail("distortion_model",
           "the file says " + quoted_for_message(model) + ", the caller " + quoted_for_message(*said));
  if (model == "fisheye" || model == "equidistant") {
    if (d.size() != 4) f.fail(keys->distortion, "a fisheye model has 4 coefficients, got " + std::to_string(d.size()));
    p.model = KannalaBrandt<double>(k[0], d[0], d[1], d[2], d[3]);
  } else if (model == "plumb_bob" || model == "radtan" || model == "rational_polynomial") {
    set_radial_tangential(&p, d, k[0], [&](std::string_view problem) { f.fail(keys->distortion, problem); });
  } else {
    f.fail("distortion_model", "expected fisheye, plumb_bob or rational_polynomial, got " + quoted_for_message(model));
  }
  if (f.has("image_width") || f.has("image_height")) {
    p.width = f.positive_integer("image_width");
    p.height = f.positive_integer("image_height");
  } else if (f.has("width") || f.has("height")) {
    p.width = f.positive_integer("width");
    p.height = f.positive_integer("height");
  }
  const bool has_r = f.has("rvec_cam_ref"), has_t = f.has("tvec_cam_ref");
  if (has_r != has_t) f.fail(has_r ? "tvec_cam_ref" : "rvec_cam_ref", "missing (the pose needs both)");
  if (has_r) {
    auto rt = f.matrix("rvec_cam_ref", 3);
    const auto t = f.matrix("tvec_cam_ref", 3);
    rt.insert(rt.end(), t.begin(), t.end());
    p.pose = pose_from_rt_cam_ref(rt);
  }
  return {out};
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera)
  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  if (const std::optional<RadialTangential> r = radial_tangential_of(p)) {
    fs << "distortion_model" << (r->d.size() == 5 ? "plumb_bob" : "rational_polynomial");
    fs << "image_width" << p.width << "image_height" << p.height;
    fs << "K"
       << cv::Mat(cv::Matx33d(r->f, 0, p.grid.principal_point.x(), 0, r->f * p.grid.pixel_scale.y(),
                              p.grid.principal_point.y(), 0, 0, 1));
    fs << "D" << cv::Mat(r->d, true);
  } else {
    const KannalaBrandtOrPinhole kb = kannala_brandt_or_pinhole(p, CameraFormat::opencv);
    fs << "distortion_model"
       << "fisheye";
    fs << "image_width" << p.width << "image_height" << p.height;
    fs << "K" << cv::Mat(cv::Matx33d(kb.fx, 0, kb.cx, 0, kb.fy, kb.cy, 0, 0, 1));
    fs << "D" << cv::Mat(cv::Matx41d(kb.k[0], kb.k[1], kb.k[2], kb.k[3]));
  }
  if (p.pose) {
    const auto rt = rt_cam_ref_from_pose(*p.pose);
    fs << "rvec_cam_ref" << cv::Mat(cv::Matx31d(rt[0], rt[1], rt[2]));
    fs << "tvec_cam_ref" << cv::Mat(cv::Matx31d(rt[3], rt[4], rt[5]));
  }
  return fs.releaseAndGetString();
}

}  // namespace

extern const FormatSpec opencv_format{
    .id = CameraFormat::opencv,
    .name = "opencv",
    .description = "OpenCV FileStorage YAML/XML",
    .extensions = {".yaml", ".yml", ".xml"},
    .models = {"kannala-brandt", "equidistant", "pinhole", "opencv"},
    .distortions = {{"tangential", {}}},
    .score = score,
    .read = read,
    .write = write,
};

}  // namespace fishcam::detail
