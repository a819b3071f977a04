// basalt calibration JSON (cereal's "value0"): kb4, ds, eucm, ucm, pinhole; one
// entry per camera in intrinsics, resolution and T_imu_cam (camera -> IMU).
#include <cmath>

#include "format.hpp"

namespace fishcam::detail {
namespace {

int score(const Content& c) {
  const auto* j = c.json();
  if (!j || !j->is_object() || !j->contains("value0")) return 0;
  const auto& v = (*j)["value0"];
  return v.is_object() && v.contains("intrinsics") ? 100 : 0;
}

std::vector<NamedCamera> read(const Content& c) {
  const DocFields top(c.json_document(), c.source());
  const DocFields v = top.object("value0");
  const size_t count = v.size("intrinsics");
  if (count == 0) v.fail("intrinsics", "no camera");
  std::vector<NamedCamera> out;
  for (size_t i = 0; i < count; ++i) {
    const DocFields cam = v.item("intrinsics", i);
    const std::string type = cam.string("camera_type");
    const DocFields k = cam.object("intrinsics");
    NamedCamera named{std::to_string(i), {}, {}};
    CameraParameters& p = named.camera;
    const double fx = k.number("fx"), fy = k.number("fy");
    set_focal(&p, fx, fy, [&](std::string_view problem) { k.fail("fx", problem); });
    p.grid.principal_point = {k.number("cx"), k.number("cy")};
    if (type == "kb4") {
      p.model = KannalaBrandt<double>(fx, k.number("k1"), k.number("k2"), k.number("k3"), k.number("k4"));
    } else if (type == "ds") {
      p.model = DoubleSphere<double>(fx, k.number("xi"), k.number("alpha"));
    } else if (type == "eucm") {
      p.model = ExtendedUnified<double>(fx, k.number("alpha"), k.number("beta"));
    } else if (type == "ucm") {
      // basalt's alpha form: xi = alpha / (1 - alpha), f = fx / (1 - alpha) (docs/conventions.md).
      const double alpha = k.number("alpha");
      if (!(alpha >= 0 && alpha < 1)) k.fail("alpha", "must be in [0, 1) for the unified model");
      p.model = Unified<double>(fx / (1 - alpha), alpha / (1 - alpha));
      p.grid.pixel_scale = {1.0, fy / fx};
    } else if (type == "pinhole") {
      p.model = Pinhole<double>(fx);
    } else {
      cam.fail("camera_type", "unsupported basalt camera type " + quoted_for_message(type) +
                                  (type == "fov" || type == "bal" || type == "pinhole-radtan8"
                                       ? " (fishcam reads kb4, ds, eucm, ucm and pinhole)"
                                       : " (expected kb4, ds, eucm, ucm or pinhole)"));
    }
    if (v.has("resolution") && i < v.size("resolution")) {
      const auto wh = v.numbers("resolution", i, 2, 2);  // [width, height]
      for (double x : wh) {
        if (!(x >= 1 && x <= (1 << 16)) || x != std::floor(x)) {
          v.fail("resolution[" + std::to_string(i) + "]", "expected positive integers <= 65536");
        }
      }
      p.width = int(wh[0]), p.height = int(wh[1]);
    }
    if (v.has("T_imu_cam") && i < v.size("T_imu_cam")) {
      const DocFields t = v.item("T_imu_cam", i);
      const Eigen::Quaterniond q(t.number("qw"), t.number("qx"), t.number("qy"), t.number("qz"));
      if (std::abs(q.norm() - 1) > 1e-6) t.fail("qw", "the quaternion must have unit norm");
      p.pose = Pose{q.normalized(), {t.number("px"), t.number("py"), t.number("pz")}};
    }
    out.push_back(std::move(named));
  }
  return out;
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera)
  const double cx = p.grid.principal_point.x(), cy = p.grid.principal_point.y(), ay = p.grid.pixel_scale.y();
  nlohmann::json k;
  std::string type;
  const auto focal = [&](double f) { k["fx"] = f, k["fy"] = f * ay, k["cx"] = cx, k["cy"] = cy; };
  const KannalaBrandtLike kb = kannala_brandt_of(p);
  if (kb.ok) {
    type = "kb4", focal(kb.f);
    k["k1"] = kb.k[0], k["k2"] = kb.k[1], k["k3"] = kb.k[2], k["k4"] = kb.k[3];
  } else if (const auto* m = std::get_if<DoubleSphere<double>>(&p.model)) {
    const auto q = m->params();
    type = "ds", focal(q[0]), k["xi"] = q[1], k["alpha"] = q[2];
  } else if (const auto* m = std::get_if<ExtendedUnified<double>>(&p.model)) {
    const auto q = m->params();
    type = "eucm", focal(q[0]), k["alpha"] = q[1], k["beta"] = q[2];
  } else if (const auto* m = std::get_if<Unified<double>>(&p.model)) {
    const auto q = m->params();  // f, xi -> the alpha form
    type = "ucm", focal(q[0] / (1 + q[1])), k["alpha"] = q[1] / (1 + q[1]);
  } else if (const auto* m = std::get_if<Pinhole<double>>(&p.model)) {
    type = "pinhole", focal(m->f());
  } else {
    cannot_hold(p, CameraFormat::basalt);
  }
  const Pose pose = p.pose.value_or(Pose{});
  const auto& q = pose.rotation;
  const auto& t = pose.translation;
  nlohmann::json v = {
      {"T_imu_cam",
       {{{"px", t.x()}, {"py", t.y()}, {"pz", t.z()}, {"qx", q.x()}, {"qy", q.y()}, {"qz", q.z()}, {"qw", q.w()}}}},
      {"intrinsics", {{{"camera_type", type}, {"intrinsics", k}}}},
      {"resolution", {{p.width, p.height}}},
  };
  return nlohmann::json{{"value0", v}}.dump(4) + "\n";
}

}  // namespace

namespace {

// One entry per camera in T_imu_cam (camera -> camera 0: the first camera stands in
// for the IMU), intrinsics and resolution.
std::string write_rig(const std::vector<CameraParameters>& cameras) {
  nlohmann::json v = {{"T_imu_cam", nlohmann::json::array()},
                      {"intrinsics", nlohmann::json::array()},
                      {"resolution", nlohmann::json::array()}};
  for (const CameraParameters& p : cameras) {
    const nlohmann::json one = nlohmann::json::parse(write(p))["value0"];
    for (const char* key : {"T_imu_cam", "intrinsics", "resolution"}) v[key].push_back(one[key][0]);
  }
  return nlohmann::json{{"value0", v}}.dump(4) + "\n";
}

}  // namespace

extern const FormatSpec basalt_format{
    .id = CameraFormat::basalt,
    .name = "basalt",
    .description = "basalt calibration JSON",
    .extensions = {".json"},
    .models = {"kannala-brandt", "equidistant", "double-sphere", "extended-unified", "unified", "pinhole"},
    .score = score,
    .read = read,
    .write = write,
    .write_rig = write_rig,
};

}  // namespace fishcam::detail
