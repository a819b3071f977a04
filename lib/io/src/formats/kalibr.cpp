// Kalibr camchain YAML (also as OpenVINS and VINS-Fusion keep it): one map per
// camera (cam0, cam1, ...) with camera_model, intrinsics, distortion_model,
// distortion_coeffs, resolution and T_cam_imu (IMU -> camera).
#include <algorithm>
#include <cmath>

#include "format.hpp"

namespace fishcam::detail {
namespace {

bool is_camera(const DocNode& n) {
  return n.kind == DocNode::Kind::map && n.find("camera_model") && n.find("intrinsics");
}

int score(const Content& c) {
  const DocNode* root = c.yaml();
  if (!root || root->kind != DocNode::Kind::map) return 0;
  for (const auto& item : root->items) {
    if (is_camera(item)) return 100;
  }
  return 0;
}

Pose pose_of(const DocFields& f, const char* key) {
  std::vector<double> m;
  const DocNode& rows = f.get(key);
  if (rows.kind != DocNode::Kind::sequence || rows.items.size() != 4) f.fail(key, "expected 4 rows of 4 numbers");
  for (size_t r = 0; r < 4; ++r) {
    const DocNode wrapper{DocNode::Kind::map, "", "", {rows.items[r]}, {"row"}};
    const auto row = DocFields(wrapper, f.source()).numbers("row", 4, 4);
    m.insert(m.end(), row.begin(), row.end());
  }
  std::string problem;
  const auto pose = pose_from_matrix(m, &problem);
  if (!pose) f.fail(key, problem);
  return *pose;
}

// resolution and T_cam_imu / T_imu_cam, where a camera has them.
void read_size_and_pose(const DocFields& f, CameraParameters* p) {
  if (f.has("resolution")) {
    const auto r = f.numbers("resolution", 2, 2);
    for (double x : r) {
      if (!(x >= 1 && x <= (1 << 16)) || x != std::floor(x)) f.fail("resolution", "expected two positive integers");
    }
    p->width = int(r[0]), p->height = int(r[1]);
  }
  if (f.has("T_cam_imu")) {
    p->pose = inverse(pose_of(f, "T_cam_imu"));  // fishcam's pose is camera -> reference (the IMU)
  } else if (f.has("T_imu_cam")) {
    p->pose = pose_of(f, "T_imu_cam");
  }
}

// camera_model, intrinsics, distortion_model and distortion_coeffs.
void read_kalibr_model(const DocFields& f, CameraParameters* camera) {
  CameraParameters& p = *camera;
  const std::string model = f.string("camera_model");
  // Kalibr itself requires distortion_model: a missing one is never taken as none
  // (coefficients would be dropped silently).
  const std::string distortion = f.string("distortion_model");
  const std::vector<double> d =
      f.has("distortion_coeffs") ? f.numbers("distortion_coeffs", 0, 8) : std::vector<double>{};
  auto fail_d = [&](std::string_view problem) { f.fail("distortion_coeffs", problem); };
  if (distortion == "none" && std::any_of(d.begin(), d.end(), [](double x) { return x != 0; })) {
    fail_d("non-zero coefficients with distortion_model none (which model are they for?)");
  }
  auto focal = [&](const std::vector<double>& k, size_t at) {
    set_focal(&p, k[at], k[at + 1], [&](std::string_view problem) { f.fail("intrinsics", problem); });
    p.grid.principal_point = {k[at + 2], k[at + 3]};
    return k[at];
  };
  auto no_distortion = [&] {
    if (distortion != "none")
      f.fail("distortion_model", "expected none for camera_model " + model + ", got " + quoted_for_message(distortion));
  };
  if (model == "pinhole") {
    const auto k = f.numbers("intrinsics", 4, 4);
    const double fx = focal(k, 0);
    if (distortion == "equidistant") {
      if (d.size() != 4) fail_d("equidistant (Kannala-Brandt) has 4 coefficients");
      p.model = KannalaBrandt<double>(fx, d[0], d[1], d[2], d[3]);
    } else if (distortion == "none") {
      p.model = Pinhole<double>(fx);
    } else if (distortion == "radtan") {
      set_radial_tangential(&p, d, fx, fail_d);
    } else {
      f.fail("distortion_model",
             "unsupported " + quoted_for_message(distortion) + " (expected equidistant, radtan or none)");
    }
  } else if (model == "omni") {
    const auto k = f.numbers("intrinsics", 5, 5);  // xi, fu, fv, pu, pv
    const double fx = focal(k, 1);
    if (distortion == "none") {
      p.model = Unified<double>(fx, k[0]);
    } else if (distortion == "radtan") {
      if (d.size() != 4) fail_d("radtan has 4 coefficients (k1, k2, p1, p2)");
      p.model = Mei<double>(fx, k[0], d[0], d[1]);
      p.distortion = TangentialDistortion{{d[2], d[3], {}}};
    } else {
      f.fail("distortion_model",
             "omni with " + quoted_for_message(distortion) +
                 " is radially symmetric but fishcam has no such model (it reads omni-none and omni-radtan)");
    }
  } else if (model == "ds") {
    no_distortion();
    const auto k = f.numbers("intrinsics", 6, 6);  // xi, alpha, fu, fv, pu, pv
    p.model = DoubleSphere<double>(focal(k, 2), k[0], k[1]);
  } else if (model == "eucm") {
    no_distortion();
    const auto k = f.numbers("intrinsics", 6, 6);  // alpha, beta, fu, fv, pu, pv
    p.model = ExtendedUnified<double>(focal(k, 2), k[0], k[1]);
  } else {
    f.fail("camera_model", "unsupported " + quoted_for_message(model) + " (expected pinhole, omni, ds or eucm)");
  }
}

std::vector<NamedCamera> read(const Content& c) {
  const DocNode& root = c.yaml_or_throw();
  std::vector<NamedCamera> out;
  std::vector<std::pair<size_t, Pose>> chained;  // T_cn_cnm1 by camera index
  for (size_t i = 0; i < root.items.size(); ++i) {
    if (!is_camera(root.items[i])) continue;
    const DocFields f(root.items[i], c.source(), root.keys[i] + ".");
    NamedCamera named{root.keys[i], {}, {}};
    CameraParameters& p = named.camera;
    read_kalibr_model(f, &p);
    read_size_and_pose(f, &p);
    if (f.has("T_cn_cnm1")) {
      if (p.pose) {
        named.notes.push_back(text_for_message(root.keys[i]) + ".T_cn_cnm1 is not read (T_cam_imu gives the pose)");
      } else {
        chained.emplace_back(out.size(), pose_of(f, "T_cn_cnm1"));
      }
    }
    out.push_back(std::move(named));
  }
  if (out.empty()) throw Error(c.source() + ": no camera (a Kalibr camchain has cam0: camera_model, intrinsics, ...)");
  // A rig without an IMU: T_cn_cnm1 (camera n-1 -> camera n) on every camera after
  // the first gives each camera's pose relative to the first (camera -> camera 0).
  if (!chained.empty()) {
    if (chained.size() + 1 != out.size() || chained.front().first != 1) {
      throw Error(c.source() + ": T_cn_cnm1 must be on every camera after the first (and only there)");
    }
    out[0].camera.pose = Pose{};
    for (const auto& [n, t] : chained) out[n].camera.pose = compose(*out[n - 1].camera.pose, inverse(t));
  }
  return out;
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera)
  const double ay = p.grid.pixel_scale.y(), cx = p.grid.principal_point.x(), cy = p.grid.principal_point.y();
  const auto focal = [&](double f) { return std::vector<double>{f, f * ay, cx, cy}; };
  std::string model, distortion = "none";
  std::vector<double> intrinsics, coeffs;
  const double p1 = p.tangential_terms().p1, p2 = p.tangential_terms().p2;
  const KannalaBrandtLike kb = kannala_brandt_of(p);
  if (kb.ok) {
    model = "pinhole", distortion = "equidistant", intrinsics = focal(kb.f), coeffs = {kb.k.begin(), kb.k.end()};
  } else if (const auto* m = std::get_if<Pinhole<double>>(&p.model)) {
    model = "pinhole", intrinsics = focal(m->f());
    if (p.tangential_terms().any()) distortion = "radtan", coeffs = {0, 0, p1, p2};
  } else if (const auto* m = std::get_if<Unified<double>>(&p.model)) {
    const auto q = m->params();
    model = "omni", intrinsics = focal(q[0]), intrinsics.insert(intrinsics.begin(), q[1]);
  } else if (const auto* m = std::get_if<Mei<double>>(&p.model)) {
    const auto q = m->params();
    model = "omni", distortion = "radtan", intrinsics = focal(q[0]), intrinsics.insert(intrinsics.begin(), q[1]);
    coeffs = {q[2], q[3], p1, p2};
  } else if (const auto* m = std::get_if<DoubleSphere<double>>(&p.model)) {
    const auto q = m->params();
    model = "ds", intrinsics = focal(q[0]), intrinsics.insert(intrinsics.begin(), {q[1], q[2]});
  } else if (const auto* m = std::get_if<ExtendedUnified<double>>(&p.model)) {
    const auto q = m->params();
    model = "eucm", intrinsics = focal(q[0]), intrinsics.insert(intrinsics.begin(), {q[1], q[2]});
  } else {
    cannot_hold(p, CameraFormat::kalibr);
  }
  std::string out = "cam0:\n";
  out += "  camera_model: " + model + "\n";
  out += "  intrinsics: " + yaml_list(intrinsics) + "\n";
  out += "  distortion_model: " + distortion + "\n";
  out += "  distortion_coeffs: " + yaml_list(coeffs) + "\n";
  out += "  resolution: [" + std::to_string(p.width) + ", " + std::to_string(p.height) + "]\n";
  if (p.pose) {
    const auto m = matrix_from_pose(inverse(*p.pose));
    out += "  T_cam_imu:\n";
    for (int r = 0; r < 4; ++r) out += "  - " + yaml_list({m[4 * r], m[4 * r + 1], m[4 * r + 2], m[4 * r + 3]}) + "\n";
  }
  return out;
}

}  // namespace

namespace {

// Every camera as camN with T_cn_cnm1 (camera n-1 -> camera n) from the poses
// (camera -> camera 0); no T_cam_imu.
std::string write_rig(const std::vector<CameraParameters>& cameras) {
  std::string out;
  for (size_t n = 0; n < cameras.size(); ++n) {
    CameraParameters alone = cameras[n];
    alone.pose.reset();
    std::string block = write(alone);
    block.replace(0, 4, "cam" + std::to_string(n));  // "cam0" -> "camN"
    out += block;
    if (n > 0) {
      const auto m = matrix_from_pose(compose(inverse(*cameras[n].pose), *cameras[n - 1].pose));
      out += "  T_cn_cnm1:\n";
      for (int r = 0; r < 4; ++r)
        out += "  - " + yaml_list({m[4 * r], m[4 * r + 1], m[4 * r + 2], m[4 * r + 3]}) + "\n";
    }
  }
  return out;
}

}  // namespace

extern const FormatSpec kalibr_format{
    .id = CameraFormat::kalibr,
    .name = "kalibr",
    .description = "Kalibr camchain YAML",
    .extensions = {".yaml", ".yml"},
    .models = {"kannala-brandt", "equidistant", "pinhole", "unified", "mei", "double-sphere", "extended-unified"},
    .distortions = {{"tangential", {"p1", "p2"}}},
    .score = score,
    .read = read,
    .write = write,
    .write_rig = write_rig,
};

}  // namespace fishcam::detail
