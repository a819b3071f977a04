#include "fishcam/error.hpp"
#include "fishcam/camera_io.hpp"

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <sstream>

#include "fishcam/atomic_file.hpp"
#include "document.hpp"
#include "python_literal.hpp"

namespace fishcam {
namespace {

using nlohmann::json;
constexpr double kDeg = 180 / std::numbers::pi;

std::string type_name(const json& j) {
  if (j.is_number()) return "number";
  return j.type_name();
}

// Typed, named access to a JSON object: every failure says file, field and problem.
class Fields {
 public:
  Fields(const json& object, std::string source, std::string prefix = "")
      : j_(object), source_(std::move(source)), prefix_(std::move(prefix)) {}

  [[noreturn]] void fail(std::string_view key, std::string_view problem) const {
    throw Error(source_ + ": " + prefix_ + std::string(key) + ": " + std::string(problem));
  }
  bool has(std::string_view key) const { return j_.contains(key); }
  const json& get(std::string_view key) const {
    const auto it = j_.find(key);
    if (it == j_.end()) fail(key, "missing");
    return *it;
  }
  double number(std::string_view key) const { return as_number(get(key), key); }
  int positive_integer(std::string_view key) const {
    const double v = number(key);
    if (!(v >= 1 && v <= (1 << 16)) || v != std::floor(v)) fail(key, "expected a positive integer <= 65536");
    return static_cast<int>(v);
  }
  std::string string(std::string_view key) const {
    const json& v = get(key);
    if (!v.is_string()) fail(key, "expected a string, got " + type_name(v));
    return v.get<std::string>();
  }
  std::vector<double> numbers(std::string_view key, size_t min_size, size_t max_size) const {
    const json& v = get(key);
    if (!v.is_array()) fail(key, "expected a list of numbers, got " + type_name(v));
    if (v.size() < min_size || v.size() > max_size) {
      fail(key, min_size == max_size ? "expected " + std::to_string(min_size) + " numbers, got " + std::to_string(v.size())
                                     : "expected " + std::to_string(min_size) + " to " + std::to_string(max_size) +
                                           " numbers, got " + std::to_string(v.size()));
    }
    std::vector<double> out;
    for (size_t i = 0; i < v.size(); ++i) out.push_back(as_number(v[i], std::string(key) + "[" + std::to_string(i) + "]"));
    return out;
  }
  Fields object(std::string_view key) const {
    const json& v = get(key);
    if (!v.is_object()) fail(key, "expected an object, got " + type_name(v));
    return Fields(v, source_, prefix_ + std::string(key) + ".");
  }
  const std::string& source() const { return source_; }

 private:
  double as_number(const json& v, std::string_view key) const {
    if (!v.is_number()) fail(key, "expected a number, got " + type_name(v));
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(key, "must be finite");
    return x;
  }
  const json& j_;
  std::string source_, prefix_;
};

// Builds the camera so its own validation errors also name the file.
CameraParameters validated(CameraParameters p, std::string_view source) {
  try {
    Camera check(p);
  } catch (const Error& e) {
    throw Error(std::string(source) + ": " + e.what());
  }
  return p;
}

// Scales the model so that a_x = 1 (formats with one focal length and an aspect).
CameraParameters with_unit_ax(CameraParameters p) {
  const double ax = p.pixel_scale.x();
  p.model = std::visit([&](const auto& m) { return RadialModel(m.scaled(ax)); }, p.model);
  p.pixel_scale = {1.0, p.pixel_scale.y() / ax};
  return p;
}

Pose pose_from_rt_cam_ref(const std::vector<double>& rt) {
  const Eigen::Vector3d r(rt[0], rt[1], rt[2]), t(rt[3], rt[4], rt[5]);
  const double angle = r.norm();
  const Eigen::Matrix3d r_cam_ref =
      angle > 0 ? Eigen::AngleAxisd(angle, r / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  Pose pose;
  pose.rotation = Eigen::Quaterniond(r_cam_ref.transpose());
  pose.translation = -(r_cam_ref.transpose() * t);
  return pose;
}

std::array<double, 6> rt_cam_ref_from_pose(const Pose& pose) {
  const Eigen::Quaterniond q_cam_ref = pose.rotation.conjugate();
  const Eigen::AngleAxisd aa(q_cam_ref);
  const Eigen::Vector3d r = aa.axis() * aa.angle();
  const Eigen::Vector3d t = -(q_cam_ref * pose.translation);
  return {r.x(), r.y(), r.z(), t.x(), t.y(), t.z()};
}

void reject_theta_limit(const CameraParameters& p, std::string_view format) {
  if (p.theta_limit) {
    throw Error("theta_limit: the " + std::string(format) + " format cannot store a user field-of-view limit");
  }
}

// A pose as JSON / from JSON: quaternion (x, y, z, w: scalar last, unit norm) and translation.
json pose_to_json(const Pose& pose, const char* quaternion_key) {
  const auto& q = pose.rotation;
  const auto& t = pose.translation;
  return {{quaternion_key, {q.x(), q.y(), q.z(), q.w()}}, {"translation", {t.x(), t.y(), t.z()}}};
}

Pose pose_from_json(const Fields& f, const char* quaternion_key) {
  const std::vector<double> q = f.numbers(quaternion_key, 4, 4);
  const std::vector<double> t = f.numbers("translation", 3, 3);
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (std::abs(norm - 1) > 1e-6) f.fail(quaternion_key, "must have unit norm, got " + std::to_string(norm));
  return Pose{Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized(), Eigen::Vector3d(t[0], t[1], t[2])};
}

// ---------------------------------------------------------------- WoodScape
// "k1", "k2", ... (appended, not `"k" + to_string(i)`: GCC 12 warns falsely on that).
std::string coefficient_key(int i) {
  std::string key = "k";
  key += std::to_string(i);
  return key;
}

CameraParameters read_woodscape(const json& root, const std::string& source) {
  const Fields top(root, source);
  const Fields in = top.object("intrinsic");
  const std::string model = in.string("model");
  if (model != "radial_poly") in.fail("model", "unsupported WoodScape model " + quoted_for_message(model) + " (expected radial_poly)");
  const double poly_order = in.number("poly_order");
  if (!(poly_order >= 1 && poly_order <= 16) || poly_order != std::floor(poly_order)) {
    in.fail("poly_order", "expected an integer in [1, 16]");
  }
  const int order = static_cast<int>(poly_order);
  std::vector<double> k;
  for (int i = 1; i <= order; ++i) k.push_back(in.number(coefficient_key(i)));
  CameraParameters p;
  p.width = in.positive_integer("width");
  p.height = in.positive_integer("height");
  // WoodScape's offsets are from the image centre in a frame whose pixel centres
  // sit at half-integers; ours sit at integers, hence the -0.5.
  p.principal_point = {p.width / 2.0 + in.number("cx_offset") - 0.5, p.height / 2.0 + in.number("cy_offset") - 0.5};
  const double aspect = in.number("aspect_ratio");
  if (!(aspect > 0)) in.fail("aspect_ratio", "must be > 0");
  p.pixel_scale = {1.0, aspect};
  p.model = Polynomial<double>(k);
  if (top.has("extrinsic")) p.pose = pose_from_json(top.object("extrinsic"), "quaternion");
  return p;
}

json write_woodscape(const CameraParameters& original) {
  reject_theta_limit(original, "WoodScape");
  const CameraParameters p = with_unit_ax(original);
  std::vector<double> k;
  if (const auto* poly = std::get_if<Polynomial<double>>(&p.model)) {
    k = poly->params();
  } else if (const auto* eq = std::get_if<Equidistant<double>>(&p.model)) {
    k = {eq->f()};
  } else {
    throw Error("model: the WoodScape format holds polynomial (and equidistant) models only, not " +
                std::string(model_name(p.model)));
  }
  while (k.size() < 4) k.push_back(0.0);
  json in = {{"model", "radial_poly"},
             {"poly_order", k.size()},
             {"width", p.width},
             {"height", p.height},
             {"cx_offset", p.principal_point.x() - p.width / 2.0 + 0.5},
             {"cy_offset", p.principal_point.y() - p.height / 2.0 + 0.5},
             {"aspect_ratio", p.pixel_scale.y()}};
  for (size_t i = 0; i < k.size(); ++i) in[coefficient_key(int(i) + 1)] = k[i];
  json root = {{"intrinsic", in}};
  if (p.pose) root["extrinsic"] = pose_to_json(*p.pose, "quaternion");
  return root;
}

// ---------------------------------------------------------------- fishcam JSON
CameraParameters read_fishcam(const json& root, const std::string& source) {
  const Fields f(root, source);
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
  return p;
}

json write_fishcam(const CameraParameters& p) {
  json root = {{"fishcam_camera", 1},
               {"width", p.width},
               {"height", p.height},
               {"principal_point", {p.principal_point.x(), p.principal_point.y()}},
               {"pixel_scale", {p.pixel_scale.x(), p.pixel_scale.y()}},
               {"model", model_name(p.model)},
               {"parameters", model_params(p.model)}};
  if (p.theta_limit) root["theta_limit_deg"] = *p.theta_limit * kDeg;
  if (p.pose) root["pose"] = pose_to_json(*p.pose, "quaternion_xyzw");
  return root;
}

// ---------------------------------------------------------------- mrcal
CameraParameters read_mrcal(const json& root, const std::string& source) {
  const Fields f(root, source);
  const std::string lensmodel = f.string("lensmodel");
  const bool pinhole = lensmodel == "LENSMODEL_PINHOLE";
  if (!pinhole && lensmodel != "LENSMODEL_STEREOGRAPHIC") {
    f.fail("lensmodel", "unsupported lens model " + lensmodel + " (fishcam reads LENSMODEL_PINHOLE and "
                        "LENSMODEL_STEREOGRAPHIC)");
  }
  const auto k = f.numbers("intrinsics", 4, 4);  // fx, fy, cx, cy
  const auto size = f.numbers("imagersize", 2, 2);
  for (int i = 0; i < 2; ++i) {
    if (!(size[i] >= 1 && size[i] <= (1 << 16)) || size[i] != std::floor(size[i])) {
      f.fail("imagersize", "expected two positive integers");
    }
  }
  if (!(k[0] > 0) || !(k[1] > 0)) f.fail("intrinsics", "fx and fy must be > 0");
  CameraParameters p;
  p.width = static_cast<int>(size[0]);
  p.height = static_cast<int>(size[1]);
  p.principal_point = {k[2], k[3]};
  p.pixel_scale = {1.0, k[1] / k[0]};
  p.model = pinhole ? RadialModel(Pinhole<double>(k[0])) : RadialModel(Stereographic<double>(k[0]));
  if (f.has("extrinsics")) p.pose = pose_from_rt_cam_ref(f.numbers("extrinsics", 6, 6));
  return p;
}

std::string write_mrcal(const CameraParameters& p) {
  reject_theta_limit(p, "mrcal");
  double f = 0;
  std::string lensmodel;
  if (const auto* m = std::get_if<Stereographic<double>>(&p.model)) {
    f = m->f(), lensmodel = "LENSMODEL_STEREOGRAPHIC";
  } else if (const auto* m = std::get_if<Pinhole<double>>(&p.model)) {
    f = m->f(), lensmodel = "LENSMODEL_PINHOLE";
  } else {
    throw Error("model: mrcal's format holds pinhole and stereographic models only, not " +
                std::string(model_name(p.model)));
  }
  const std::array<double, 6> rt = p.pose ? rt_cam_ref_from_pose(*p.pose) : std::array<double, 6>{};
  char buffer[1024];
  std::snprintf(buffer, sizeof buffer,
                "{\n"
                "    'lensmodel':  '%s',\n\n"
                "    # intrinsics are fx,fy,cx,cy\n"
                "    'intrinsics': [ %.17g, %.17g, %.17g, %.17g,],\n\n"
                "    # extrinsics are rt_fromref (rt_cam_ref)\n"
                "    'extrinsics': [ %.17g, %.17g, %.17g, %.17g, %.17g, %.17g,],\n\n"
                "    'imagersize': [ %d, %d,],\n"
                "}\n",
                lensmodel.c_str(), f * p.pixel_scale.x(), f * p.pixel_scale.y(), p.principal_point.x(),
                p.principal_point.y(), rt[0], rt[1], rt[2], rt[3], rt[4], rt[5], p.width, p.height);
  return buffer;
}

// ---------------------------------------------------------------- OpenCV fisheye
std::string_view trimmed_start(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  return s;
}

// OpenCV's FileStorage files (YAML or XML), read with yaml-cpp / pugixml
// (document.hpp), never with cv::FileStorage: its parser crashes on bad input.
CameraParameters read_opencv(std::string_view content, const std::string& source) {
  auto fail = [&](std::string_view field, std::string_view problem) -> void {
    throw Error(source + ": " + std::string(field) + ": " + std::string(problem));
  };
  const std::string_view start = trimmed_start(content);
  const detail::DocNode root =
      start.starts_with("<") ? detail::parse_xml(content, source) : detail::parse_yaml(content, source);
  if (root.kind != detail::DocNode::Kind::map) throw Error(source + ": not an OpenCV YAML/XML file (no top-level map)");
  auto node = [&](const char* name, const char* alias) {
    const detail::DocNode* n = root.find(name);
    return !n && alias ? root.find(alias) : n;
  };
  auto number = [&](const std::string& text, const std::string& field) {
    const std::string trimmed(trimmed_start(text));
    // YAML's own spellings of the non-finite numbers (OpenCV writes them).
    for (const char* special : {".nan", ".NaN", ".NAN", ".inf", ".Inf", ".INF", "-.inf", "-.Inf", "-.INF", "+.inf"}) {
      if (trimmed == special) fail(field, "must be finite");
    }
    char* end = nullptr;
    const double v = std::strtod(trimmed.c_str(), &end);
    if (trimmed.empty() || end == trimmed.c_str() || !trimmed_start(end).empty()) {
      fail(field, "expected a number, got " + quoted_for_message(text));
    }
    if (!std::isfinite(v)) fail(field, "must be finite");
    return v;
  };
  auto matrix = [&](const char* name, const char* alias, int count) {
    const detail::DocNode* n = node(name, alias);
    if (!n) fail(name, "missing");
    if (n->kind != detail::DocNode::Kind::map || !n->find("rows") || !n->find("cols") || !n->find("data")) {
      fail(name, "expected an opencv-matrix (rows, cols, dt, data)");
    }
    const double rows = number(n->find("rows")->scalar, std::string(name) + ".rows");
    const double cols = number(n->find("cols")->scalar, std::string(name) + ".cols");
    if (rows < 1 || cols < 1 || rows * cols != count) {
      fail(name, "expected " + std::to_string(count) + " elements (rows x cols)");
    }
    std::vector<std::string> texts;
    const detail::DocNode& data = *n->find("data");
    if (data.kind == detail::DocNode::Kind::sequence) {
      for (const auto& item : data.items) {
        if (item.kind != detail::DocNode::Kind::scalar) fail(std::string(name) + ".data", "expected numbers");
        texts.push_back(item.scalar);
      }
    } else if (data.kind == detail::DocNode::Kind::scalar) {  // XML: whitespace-separated
      std::istringstream words(data.scalar);
      for (std::string word; words >> word && texts.size() <= size_t(count);) texts.push_back(word);
    }
    if (texts.size() != size_t(count)) {
      fail(std::string(name) + ".data", "expected " + std::to_string(count) + " numbers");
    }
    std::vector<double> v;
    for (size_t i = 0; i < texts.size(); ++i) {
      v.push_back(number(texts[i], std::string(name) + ".data[" + std::to_string(i) + "]"));
    }
    return v;
  };
  auto integer = [&](const char* name) {
    const detail::DocNode* n = root.find(name);
    if (!n) fail(name, "missing");
    if (n->kind != detail::DocNode::Kind::scalar) fail(name, "expected an integer");
    char* end = nullptr;
    const std::string text(trimmed_start(n->scalar));
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || !trimmed_start(end).empty()) {
      fail(name, "expected an integer, got " + quoted_for_message(n->scalar));
    }
    if (!(v >= 1 && v <= (1 << 16)) || v != std::floor(v)) fail(name, "expected a positive integer <= 65536");
    return static_cast<int>(v);
  };
  if (const detail::DocNode* model = root.find("distortion_model")) {
    std::string name = model->kind == detail::DocNode::Kind::scalar ? model->scalar : "";
    if (name.size() >= 2 && name.front() == '"' && name.back() == '"') name = name.substr(1, name.size() - 2);
    if (name != "fisheye") fail("distortion_model", "only 'fisheye' is supported, got " + quoted_for_message(name));
  }
  const auto k = matrix("K", "camera_matrix", 9);
  const auto d = matrix("D", "distortion_coefficients", 4);
  if (!(k[0] > 0) || !(k[4] > 0)) fail("K", "fx and fy must be > 0");
  if (k[1] != 0) fail("K", "skew (K[0][1]) is not supported");
  if (k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1) fail("K", "expected [fx 0 cx; 0 fy cy; 0 0 1]");
  CameraParameters p;
  p.width = integer("image_width");
  p.height = integer("image_height");
  p.principal_point = {k[2], k[5]};
  p.pixel_scale = {1.0, k[4] / k[0]};
  p.model = KannalaBrandt<double>(k[0], d[0], d[1], d[2], d[3]);
  const bool has_r = root.find("rvec_cam_ref") != nullptr, has_t = root.find("tvec_cam_ref") != nullptr;
  if (has_r != has_t) fail(has_r ? "tvec_cam_ref" : "rvec_cam_ref", "missing (the pose needs both)");
  if (has_r) {
    auto rt = matrix("rvec_cam_ref", nullptr, 3);
    const auto t = matrix("tvec_cam_ref", nullptr, 3);
    rt.insert(rt.end(), t.begin(), t.end());
    p.pose = pose_from_rt_cam_ref(rt);
  }
  return p;
}

std::string write_opencv(const CameraParameters& original) {
  reject_theta_limit(original, "OpenCV");
  const CameraParameters p = with_unit_ax(original);
  std::array<double, 5> kb{};
  if (const auto* m = std::get_if<KannalaBrandt<double>>(&p.model)) {
    const auto params = m->params();
    std::copy(params.begin(), params.end(), kb.begin());
  } else if (const auto* m = std::get_if<Equidistant<double>>(&p.model)) {
    kb = {m->f(), 0, 0, 0, 0};
  } else {
    throw Error("model: OpenCV's fisheye format holds kannala-brandt (and equidistant) models only, not " +
                std::string(model_name(p.model)));
  }
  const double fx = kb[0], fy = kb[0] * p.pixel_scale.y();
  const cv::Matx33d K(fx, 0, p.principal_point.x(), 0, fy, p.principal_point.y(), 0, 0, 1);
  const cv::Matx41d D(kb[1], kb[2], kb[3], kb[4]);
  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  fs << "distortion_model" << "fisheye";
  fs << "image_width" << p.width << "image_height" << p.height;
  fs << "K" << cv::Mat(K) << "D" << cv::Mat(D);
  if (p.pose) {
    const auto rt = rt_cam_ref_from_pose(*p.pose);
    fs << "rvec_cam_ref" << cv::Mat(cv::Matx31d(rt[0], rt[1], rt[2]));
    fs << "tvec_cam_ref" << cv::Mat(cv::Matx31d(rt[3], rt[4], rt[5]));
  }
  return fs.releaseAndGetString();
}


json parse_json(std::string_view content, const std::string& source) {
  try {
    return json::parse(content);
  } catch (const json::exception& e) {  // parse errors, and number overflow ('1e400')
    std::string what = e.what();
    if (const auto pos = what.find("] "); pos != std::string::npos) what = what.substr(pos + 2);
    throw Error(source + ": not valid JSON (" + quoted_for_message(what, 120) + ")");
  }
}

}  // namespace

std::string_view to_string(CameraFormat format) {
  switch (format) {
    case CameraFormat::woodscape: return "woodscape";
    case CameraFormat::mrcal: return "mrcal";
    case CameraFormat::opencv: return "opencv";
    case CameraFormat::fishcam: return "fishcam";
  }
  return "?";
}

std::optional<CameraFormat> parse_camera_format(std::string_view name) {
  for (auto f : {CameraFormat::woodscape, CameraFormat::mrcal, CameraFormat::opencv, CameraFormat::fishcam}) {
    if (name == to_string(f)) return f;
  }
  return std::nullopt;
}

CameraFormat detect_camera_format(std::string_view content, std::string_view source_name) {
  const std::string_view s = trimmed_start(content);
  if (s.starts_with("%YAML") || s.starts_with("<?xml") || s.find("opencv-matrix") != std::string_view::npos) {
    return CameraFormat::opencv;
  }
  if (s.find("'lensmodel'") != std::string_view::npos || s.find("\"lensmodel\"") != std::string_view::npos) {
    return CameraFormat::mrcal;
  }
  if (s.find("\"fishcam_camera\"") != std::string_view::npos) return CameraFormat::fishcam;
  if (s.find("\"intrinsic\"") != std::string_view::npos) return CameraFormat::woodscape;
  if (s.empty()) throw Error(std::string(source_name) + ": empty file");
  throw Error(std::string(source_name) +
              ": unrecognised camera file (expected WoodScape JSON, fishcam JSON, mrcal .cameramodel or OpenCV "
              "fisheye YAML/XML)");
}

CameraParameters parse_camera(std::string_view content, std::string_view source_name,
                              std::optional<CameraFormat> format) {
  const std::string source(source_name);
  CameraParameters p;
  switch (format ? *format : detect_camera_format(content, source_name)) {
    case CameraFormat::opencv:
      p = read_opencv(content, source);
      break;
    case CameraFormat::mrcal: {
      json root;
      try {
        root = detail::parse_python_literal(content);
      } catch (const Error& e) {
        throw Error(source + ": not a valid mrcal .cameramodel (" + e.what() + ")");
      }
      if (!root.is_object()) throw Error(source + ": not a valid mrcal .cameramodel (expected a dict)");
      p = read_mrcal(root, source);
      break;
    }
    case CameraFormat::fishcam:
    case CameraFormat::woodscape: {
      const json root = parse_json(content, source);
      if (!root.is_object()) throw Error(source + ": expected a JSON object at the top level");
      p = root.contains("fishcam_camera") ? read_fishcam(root, source) : read_woodscape(root, source);
      break;
    }
  }
  return validated(std::move(p), source_name);
}

Camera read_camera(const std::filesystem::path& path, CameraFormat* format) {
  return read_camera(path, CameraReadOptions{}, format);
}

Camera read_camera(const std::filesystem::path& path, const CameraReadOptions& options, CameraFormat* format) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw Error(path.string() + ": is a directory, not a camera file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot open (does it exist and is it readable?)");
  std::ostringstream content;
  content << in.rdbuf();
  if (in.bad()) throw Error(path.string() + ": read error");
  const CameraFormat detected = options.format ? *options.format : detect_camera_format(content.str(), path.string());
  if (format) *format = detected;
  // Every format read today holds exactly one camera and its image size.
  if (options.camera && *options.camera != "0") {
    throw Error(path.string() + ": camera: a " + std::string(to_string(detected)) +
                " file holds one camera (index 0), got " + quoted_for_message(*options.camera) );
  }
  CameraParameters p = parse_camera(content.str(), path.string(), detected);
  if (options.image_size && (options.image_size->first != p.width || options.image_size->second != p.height)) {
    throw Error(path.string() + ": image_size: the file says " + std::to_string(p.width) + "x" +
                std::to_string(p.height) + ", got " + std::to_string(options.image_size->first) + "x" +
                std::to_string(options.image_size->second));
  }
  return Camera(std::move(p));
}

std::string camera_info_json(const Camera& camera, std::optional<CameraFormat> format) {
  constexpr double kToDeg = 180 / std::numbers::pi;
  const auto& p = camera.parameters();
  const auto& d = camera.domain();
  const auto fov = camera.field_of_view_deg();
  json j = {
      {"format", format ? json(to_string(*format)) : json(nullptr)},
      {"model", model_name(p.model)},
      {"parameters", model_params(p.model)},
      {"width", p.width},
      {"height", p.height},
      {"cx", p.principal_point.x()},
      {"cy", p.principal_point.y()},
      {"pixel_scale", {p.pixel_scale.x(), p.pixel_scale.y()}},
      {"theta_max_deg", d.theta_max * kToDeg},
      {"theta_max_closed", d.closed},
      {"theta_max_limited_by", to_string(d.limited_by)},
      {"rho_max_px", d.closed ? json(d.rho_max) : json(nullptr)},
      {"fov_deg", {{"horizontal", fov.horizontal}, {"vertical", fov.vertical}, {"diagonal", fov.diagonal}}},
      {"inverse_table", {{"cells", camera.inverse_table().cells()},
                         {"fallback_cells", camera.inverse_table().fallback_cells()},
                         {"worst_error_px", camera.inverse_table().worst_error_px()}}},
  };
  if (p.pose) {
    const auto& q = p.pose->rotation;
    const auto& t = p.pose->translation;
    j["pose"] = {{"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}}, {"translation", {t.x(), t.y(), t.z()}}};
  }
  return j.dump();
}

namespace {

std::string formatted(const CameraParameters& camera, CameraFormat format) {
  switch (format) {
    case CameraFormat::woodscape: return write_woodscape(camera).dump(2) + "\n";
    case CameraFormat::fishcam: return write_fishcam(camera).dump(2) + "\n";
    case CameraFormat::mrcal: return write_mrcal(camera);
    case CameraFormat::opencv: return write_opencv(camera);
  }
  throw Error("unknown camera format");
}

}  // namespace

std::string format_camera(const CameraParameters& camera, CameraFormat format) {
  Camera check(camera);  // never write a camera we would refuse to read
  std::string content = formatted(camera, format);
  // Nor a file our own reader refuses (a value that overflows in the format's
  // parameterisation, say): read it back before anyone can write it.
  try {
    parse_camera(content, "", format);
  } catch (const Error& e) {
    std::string why = e.what();
    if (why.rfind(": ", 0) == 0) why = why.substr(2);
    throw Error("the " + std::string(to_string(format)) + " format cannot hold this camera (" + why + ")");
  }
  return content;
}

void write_camera(const CameraParameters& camera, const std::filesystem::path& path, CameraFormat format,
                  bool overwrite) {
  write_file_atomically(path, format_camera(camera, format), overwrite);
}

}  // namespace fishcam
