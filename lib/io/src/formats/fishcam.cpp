// fishcam's own JSON: every model of the registry, as it is.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "format.hpp"

namespace fishcam::detail {
namespace {

constexpr double kDeg = 180 / std::numbers::pi;

int score(const Content& c) {
  const auto* j = c.json();
  return j && j->is_object() && (j->contains("fishcam_camera") || j->contains("fishcam_rig")) ? 100 : 0;
}

// "calibration": {"theta_max_deg", "theta_max_by_azimuth_deg" (one per 15-degree
// sector, null where no corner fell), "covariance" (rows; optional)}.
CalibrationRecord read_calibration(const DocFields& f) {
  CalibrationRecord r;
  r.theta_max = f.number("theta_max_deg") / kDeg;
  const DocNode& sectors = f.get("theta_max_by_azimuth_deg");
  if (sectors.kind != DocNode::Kind::sequence || sectors.items.size() != size_t(CalibrationRecord::kAzimuthSectors)) {
    f.fail("theta_max_by_azimuth_deg", "expected a list of " + std::to_string(CalibrationRecord::kAzimuthSectors) +
                                           " angles (null where unobserved)");
  }
  for (size_t k = 0; k < sectors.items.size(); ++k) {
    const DocNode& item = sectors.items[k];
    r.theta_max_by_azimuth[k] =
        item.kind == DocNode::Kind::null
            ? std::numeric_limits<double>::quiet_NaN()
            : DocFields::parse_number(item.scalar, [&](std::string_view problem) {
                f.fail("theta_max_by_azimuth_deg", "item " + std::to_string(k) + ": " + std::string(problem));
              }) / kDeg;
  }
  if (f.has("covariance")) {
    const size_t n = f.size("covariance");
    if (n == 0 || n > size_t(CalibrationRecord::kMaxCovarianceRows)) {
      f.fail("covariance", "expected a square matrix of at most " +
                               std::to_string(CalibrationRecord::kMaxCovarianceRows) + " rows, as a list of rows");
    }
    r.covariance.resize(Eigen::Index(n), Eigen::Index(n));
    for (size_t i = 0; i < n; ++i) {
      const auto row = f.numbers("covariance", i, n, n);
      for (size_t j = 0; j < n; ++j) r.covariance(Eigen::Index(i), Eigen::Index(j)) = row[j];
    }
  }
  return r;
}

nlohmann::json calibration_json(const CalibrationRecord& r) {
  nlohmann::json sectors = nlohmann::json::array();
  for (double a : r.theta_max_by_azimuth)
    sectors.push_back(std::isnan(a) ? nlohmann::json(nullptr) : nlohmann::json(a * kDeg));
  nlohmann::json j = {{"theta_max_deg", r.theta_max * kDeg}, {"theta_max_by_azimuth_deg", sectors}};
  if (r.covariance.size() > 0) {
    nlohmann::json rows = nlohmann::json::array();
    for (Eigen::Index i = 0; i < r.covariance.rows(); ++i) {
      rows.push_back(std::vector<double>(r.covariance.row(i).begin(), r.covariance.row(i).end()));
    }
    j["covariance"] = rows;
  }
  return j;
}

// "tangential": {"p1", "p2", "s1", "s2", "s3", "s4"} (fishcam/core/tangential.hpp); absent terms are 0.
// Each plane distortion under its registry name: "tangential": {"p1": ..., ...} (absent
// terms are 0), "mrcal_lens": {"lensmodel": "LENSMODEL_...", "values": [...]}.
template <class Part>
Part read_part(const DocFields& parent, std::string_view key) {
  const DocFields f = parent.object(key);
  if constexpr (std::is_same_v<Part, TangentialDistortion>) {
    if (f.node().kind != DocNode::Kind::map) f.fail("", "expected an object of p1, p2, s1..s4");
    for (const std::string& key : f.node().keys) {
      if (std::find(TangentialTerms::kNames.begin(), TangentialTerms::kNames.end(), key) ==
          TangentialTerms::kNames.end()) {
        f.fail(key, "unknown tangential term (expected p1, p2, s1, s2, s3, s4)");
      }
    }
    std::array<double, 6> values{};
    for (size_t i = 0; i < values.size(); ++i) {
      if (f.has(TangentialTerms::kNames[i])) values[i] = f.number(TangentialTerms::kNames[i]);
    }
    return {TangentialTerms::from_values(values)};
  } else if constexpr (std::is_same_v<Part, MrcalLensDistortion>) {
    try {
      return Part::from_numbers(f.string("lensmodel"), f.numbers("values", 0, kMaxDocumentNodes));
    } catch (const Error& e) {
      parent.fail(key, e.what());
    }
  } else {
    static_assert(sizeof(Part) == 0, "the fishcam JSON reader must read every plane distortion");
  }
}

nlohmann::json part_json(const PlaneDistortion& distortion) {
  return std::visit(
      [](const auto& part) -> nlohmann::json {
        using Part = std::decay_t<decltype(part)>;
        if constexpr (std::is_same_v<Part, NoPlaneDistortion>) {
          return nullptr;
        } else if constexpr (std::is_same_v<Part, TangentialDistortion>) {
          nlohmann::json terms;
          for (size_t i = 0; i < TangentialTerms::kNames.size(); ++i) {
            terms[std::string(TangentialTerms::kNames[i])] = part.terms.values()[i];
          }
          return terms;
        } else if constexpr (std::is_same_v<Part, MrcalLensDistortion>) {
          return {{"lensmodel", part.lens->lensmodel()}, {"values", part.lens->values()}};
        } else {
          static_assert(sizeof(Part) == 0, "the fishcam JSON writer must write every plane distortion");
        }
      },
      distortion);
}

// The camera's plane distortion: at most one registered part's key (files written
// before CAHVOR and LONLAT/LATLON were read call mrcal_lens "spline").
PlaneDistortion read_distortion(const DocFields& f) {
  std::optional<PlaneDistortion> found;
  std::string found_key;
  const auto read_key = [&]<class Part>(std::string_view key) {
    if (!f.has(key)) return;
    if (found) f.fail(key, "a camera has one plane distortion, and " + found_key + " is given too");
    found = read_part<Part>(f, key);
    found_key = key;
  };
  PlaneDistortionRegistry::for_each([&]<class Part>() {
    if constexpr (!std::is_same_v<Part, NoPlaneDistortion>) read_key.template operator()<Part>(Part::kName);
  });
  read_key.template operator()<MrcalLensDistortion>("spline");
  return found ? *found : PlaneDistortion{};
}

CameraParameters read_camera_fields(const DocFields& f) {
  CameraParameters p;
  p.width = f.positive_integer("width");
  p.height = f.positive_integer("height");
  const auto pp = f.numbers("principal_point", 2, 2);
  const auto scale = f.numbers("pixel_scale", 2, 2);
  p.grid.principal_point = {pp[0], pp[1]};
  p.grid.pixel_scale = {scale[0], scale[1]};
  const std::string name = f.string("model");
  const auto params = f.numbers("parameters", 1, 64);
  try {
    p.model = make_model(name, params);
  } catch (const Error& e) {
    f.fail("model", e.what());
  }
  p.distortion = read_distortion(f);
  if (f.has("skew")) {  // {"xy": ..., "yx": ...} (CameraParameters::skew); an absent one is 0
    const DocFields s = f.object("skew");
    if (s.node().kind != DocNode::Kind::map) s.fail("", "expected an object of xy, yx");
    for (const std::string& key : s.node().keys) {
      if (key != "xy" && key != "yx") s.fail(key, "unknown skew term (expected xy, yx)");
    }
    p.grid.skew = {s.has("xy") ? s.number("xy") : 0.0, s.has("yx") ? s.number("yx") : 0.0};
  }
  if (f.has("theta_limit_deg")) p.theta_limit = f.number("theta_limit_deg") / kDeg;
  if (f.has("theta_limit_by_azimuth_deg")) {
    const auto limits = f.numbers("theta_limit_by_azimuth_deg", kAzimuthSectors, kAzimuthSectors);
    AzimuthSectors& by_azimuth = p.theta_limit_by_azimuth.emplace();
    for (size_t k = 0; k < by_azimuth.size(); ++k) by_azimuth[k] = limits[k] / kDeg;
  }
  if (f.has("pose")) p.pose = pose_from_json(f.object("pose"), "quaternion_xyzw");
  if (f.has("calibration")) p.calibration = read_calibration(f.object("calibration"));
  return p;
}

// One camera ({"fishcam_camera": 1, ...}) or a rig ({"fishcam_rig": 1, "cameras":
// [{"name": ..., the camera's fields}, ...]}, poses camera -> camera 0).
std::vector<NamedCamera> read(const Content& c) {
  const DocFields f(c.json_document(), c.source());
  if (f.has("fishcam_rig")) {
    if (f.number("fishcam_rig") != 1) f.fail("fishcam_rig", "unsupported format version (this build reads version 1)");
    const size_t n = f.size("cameras");
    if (n == 0) f.fail("cameras", "expected a list of cameras");
    std::vector<NamedCamera> out;
    for (size_t i = 0; i < n; ++i) {
      const DocFields camera = f.item("cameras", i);
      out.push_back({camera.has("name") ? camera.string("name") : std::to_string(i), read_camera_fields(camera), {}});
    }
    return out;
  }
  const double version = f.number("fishcam_camera");
  if (version != 1) f.fail("fishcam_camera", "unsupported format version (this build reads version 1)");
  return {{"0", read_camera_fields(f), {}}};
}

nlohmann::json camera_json(const CameraParameters& p) {
  nlohmann::json root = {{"width", p.width},
                         {"height", p.height},
                         {"principal_point", {p.grid.principal_point.x(), p.grid.principal_point.y()}},
                         {"pixel_scale", {p.grid.pixel_scale.x(), p.grid.pixel_scale.y()}},
                         {"model", model_name(p.model)},
                         {"parameters", model_params(p.model)}};
  if (displaces(p.distortion)) root[std::string(distortion_name(p.distortion))] = part_json(p.distortion);
  if (p.grid.skew.any()) root["skew"] = {{"xy", p.grid.skew.xy}, {"yx", p.grid.skew.yx}};
  if (p.theta_limit) root["theta_limit_deg"] = *p.theta_limit * kDeg;
  if (p.theta_limit_by_azimuth) {
    nlohmann::json& limits = root["theta_limit_by_azimuth_deg"] = nlohmann::json::array();
    for (double a : *p.theta_limit_by_azimuth) limits.push_back(a * kDeg);
  }
  if (p.pose) root["pose"] = pose_to_json(*p.pose, "quaternion_xyzw");
  if (p.calibration) root["calibration"] = calibration_json(*p.calibration);
  return root;
}

std::string write(const CameraParameters& p) {
  nlohmann::json root = {{"fishcam_camera", 1}};
  root.update(camera_json(p));
  return root.dump(2) + "\n";
}

std::string write_rig(const std::vector<CameraParameters>& cameras) {
  nlohmann::json list = nlohmann::json::array();
  for (size_t i = 0; i < cameras.size(); ++i) {
    nlohmann::json camera = {{"name", "cam" + std::to_string(i)}};
    camera.update(camera_json(cameras[i]));
    list.push_back(camera);
  }
  return nlohmann::json{{"fishcam_rig", 1}, {"cameras", list}}.dump(2) + "\n";
}

}  // namespace

extern const FormatSpec fishcam_format{
    .id = CameraFormat::fishcam,
    .name = "fishcam",
    .description = "fishcam camera JSON",
    .extensions = {".json"},
    .models = {},
    .distortions = {{"tangential", {}}, {"mrcal_lens", {}}},
    .score = score,
    .read = read,
    .write = write,
    .write_rig = write_rig,
    .holds = {.skew = true, .theta_limit = true, .pixel_scale = true, .calibration_record = true},
};

}  // namespace fishcam::detail
