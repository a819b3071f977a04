// COLMAP cameras.txt: one camera per line, "CAMERA_ID MODEL WIDTH HEIGHT PARAMS...".
// COLMAP puts the centre of the top-left pixel at (0.5, 0.5): cx, cy - 0.5 on read,
// + 0.5 on write (docs/formats.md).
#include <cmath>
#include <sstream>

#include "format.hpp"

namespace fishcam::detail {
namespace {

struct ColmapModel {
  const char* name;
  int params;
};
// Every COLMAP model, so that the ones fishcam cannot hold are named in the refusal.
constexpr ColmapModel kModels[] = {{"SIMPLE_PINHOLE", 3},
                                   {"PINHOLE", 4},
                                   {"SIMPLE_RADIAL", 4},
                                   {"RADIAL", 5},
                                   {"OPENCV", 8},
                                   {"OPENCV_FISHEYE", 8},
                                   {"FULL_OPENCV", 12},
                                   {"FOV", 5},
                                   {"SIMPLE_RADIAL_FISHEYE", 4},
                                   {"RADIAL_FISHEYE", 5},
                                   {"THIN_PRISM_FISHEYE", 12},
                                   {"RAD_TAN_THIN_PRISM_FISHEYE", 16}};

const ColmapModel* find_model(const std::string& name) {
  for (const auto& m : kModels) {
    if (name == m.name) return &m;
  }
  return nullptr;
}

std::vector<std::vector<std::string>> data_lines(std::string_view text) {
  std::vector<std::vector<std::string>> out;
  std::istringstream in{std::string(text)};
  for (std::string line; std::getline(in, line);) {
    std::istringstream words(line);
    std::vector<std::string> tokens;
    for (std::string w; words >> w;) tokens.push_back(w);
    if (!tokens.empty() && tokens[0][0] != '#') out.push_back(tokens);
  }
  return out;
}

int score(const Content& c) {
  if (c.text().size() > (1 << 20)) return 0;
  const auto lines = data_lines(c.text());
  if (lines.empty()) return 0;
  for (const auto& t : lines) {
    if (t.size() < 4 || !find_model(t[1])) return 0;
  }
  return 90;
}

std::vector<NamedCamera> read(const Content& c) {
  std::vector<NamedCamera> out;
  for (const auto& t : data_lines(c.text())) {
    const std::string where = c.source() + ": camera " + text_for_message(t[0]) + ": ";
    auto fail = [&](std::string_view problem) -> void { throw Error(where + std::string(problem)); };
    if (t.size() < 4) fail("expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS...");
    const ColmapModel* model = find_model(t[1]);
    if (!model) fail("unknown COLMAP model " + quoted_for_message(t[1]));
    if (int(t.size()) != 4 + model->params) {
      fail(text_for_message(t[1]) + " has " + std::to_string(model->params) + " parameters, got " +
           std::to_string(t.size() - 4));
    }
    std::vector<double> v;
    for (size_t i = 2; i < t.size(); ++i) {
      v.push_back(DocFields::parse_number(t[i], [&](std::string_view problem) {
        fail("value " + quoted_for_message(t[i]) + ": " + std::string(problem));
      }));
    }
    NamedCamera named{t[0], {}, {}};
    CameraParameters& p = named.camera;
    for (int i = 0; i < 2; ++i) {
      if (!(v[i] >= 1 && v[i] <= (1 << 16)) || v[i] != std::floor(v[i]))
        fail("WIDTH and HEIGHT must be positive integers");
    }
    p.width = int(v[0]), p.height = int(v[1]);
    const std::vector<double> q(v.begin() + 2, v.end());
    const std::string name = t[1];
    auto focal = [&](double fx, double fy, double cx, double cy) {
      set_focal(&p, fx, fy, fail);
      p.grid.principal_point = {cx - 0.5, cy - 0.5};
    };
    if (name == "SIMPLE_PINHOLE") {
      focal(q[0], q[0], q[1], q[2]), p.model = Pinhole<double>(q[0]);
    } else if (name == "PINHOLE") {
      focal(q[0], q[1], q[2], q[3]), p.model = Pinhole<double>(q[0]);
    } else if (name == "OPENCV_FISHEYE") {
      focal(q[0], q[1], q[2], q[3]), p.model = KannalaBrandt<double>(q[0], q[4], q[5], q[6], q[7]);
    } else if (name == "SIMPLE_RADIAL_FISHEYE") {
      focal(q[0], q[0], q[1], q[2]), p.model = KannalaBrandt<double>(q[0], q[3], 0, 0, 0);
    } else if (name == "RADIAL_FISHEYE") {
      focal(q[0], q[0], q[1], q[2]), p.model = KannalaBrandt<double>(q[0], q[3], q[4], 0, 0);
    } else if (name == "SIMPLE_RADIAL" || name == "RADIAL" || name == "OPENCV" || name == "FULL_OPENCV") {
      // OpenCV's pinhole distortion in COLMAP's parameter order (k1[, k2[, p1, p2[, k3, k4, k5, k6]]]).
      const bool one_focal = name == "SIMPLE_RADIAL" || name == "RADIAL";
      if (one_focal) {
        focal(q[0], q[0], q[1], q[2]);
      } else {
        focal(q[0], q[1], q[2], q[3]);
      }
      std::vector<double> d(q.begin() + (one_focal ? 3 : 4), q.end());
      d.resize(d.size() <= 4 ? 4 : 8, 0.0);
      set_radial_tangential(
          &p, d, q[0], [&](std::string_view problem) { fail(text_for_message(name) + ": " + std::string(problem)); });
    } else if (name == "FOV") {
      fail(text_for_message(name) + " is radially symmetric but fishcam has no such model");
    } else {
      fail(text_for_message(name) + " is not a model fishcam reads (it reads the OpenCV, pinhole and fisheye ones)");
    }
    out.push_back(std::move(named));
  }
  if (out.empty()) throw Error(c.source() + ": no camera line");
  return out;
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera)
  std::vector<double> params;
  std::string model;
  std::optional<RadialTangential> r = radial_tangential_of(p);
  if (r && (r->rational || p.tangential_terms().any())) {
    model = "FULL_OPENCV";
    r->d.resize(8, 0.0);
    params = {r->f, r->f * p.grid.pixel_scale.y(), p.grid.principal_point.x() + 0.5, p.grid.principal_point.y() + 0.5};
    params.insert(params.end(), r->d.begin(), r->d.end());
  } else {
    const KannalaBrandtOrPinhole kb = kannala_brandt_or_pinhole(p, CameraFormat::colmap);
    model = kb.pinhole ? "PINHOLE" : "OPENCV_FISHEYE";
    params = {kb.fx, kb.fy, kb.cx + 0.5, kb.cy + 0.5};
    if (!kb.pinhole) params.insert(params.end(), kb.k.begin(), kb.k.end());
  }
  std::string out = "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  out += "1 " + model + " ";
  out += std::to_string(p.width);
  out += " ";
  out += std::to_string(p.height);
  for (double x : params) {
    out += ' ';
    out += yaml_number(x);
  }
  return out + "\n";
}

}  // namespace

extern const FormatSpec colmap_format{
    .id = CameraFormat::colmap,
    .name = "colmap",
    .description = "COLMAP cameras.txt",
    .extensions = {".txt"},
    .models = {"kannala-brandt", "equidistant", "pinhole", "opencv"},
    .distortions = {{"tangential", {"p1", "p2"}}},
    .score = score,
    .read = read,
    .write = write,
};

}  // namespace fishcam::detail
