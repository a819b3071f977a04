// mrcal .cameramodel (a Python literal): LENSMODEL_PINHOLE, LENSMODEL_STEREOGRAPHIC,
// LENSMODEL_OPENCV4/5/8/12 (tangential terms included), and the lens models evaluated by
// libmrcal on a base model's plane (fishcam/core/mrcal_lens.hpp: splined, CAHVOR, CAHVORE, LONLAT, LATLON).
#include <cmath>
#include <cstdio>
#include <span>

#include "fishcam/core/model_registry.hpp"
#include "format.hpp"

namespace fishcam::detail {
namespace {

int score(const Content& c) {
  // Cheap first: only text that mentions the key is parsed.
  if (c.text().find("lensmodel") == std::string_view::npos) return 0;
  const auto* j = c.python_literal();
  return j && j->is_object() && j->contains("lensmodel") ? 100 : 0;
}

std::vector<NamedCamera> read(const Content& c) {
  const DocNode* root = c.python_literal_document();
  if (!root) throw Error(c.source() + ": not a valid mrcal .cameramodel (" + c.python_literal_error() + ")");
  if (root->kind != DocNode::Kind::map) throw Error(c.source() + ": not a valid mrcal .cameramodel (expected a dict)");
  const DocFields f(*root, c.source());
  const std::string lensmodel = f.string("lensmodel");
  const bool pinhole = lensmodel == "LENSMODEL_PINHOLE";
  // LENSMODEL_OPENCVn: n radial-tangential coefficients in OpenCV's order after fx, fy, cx, cy.
  size_t opencv_coefficients = 0;
  for (size_t n : {4, 5, 8, 12}) {
    if (lensmodel == "LENSMODEL_OPENCV" + std::to_string(n)) opencv_coefficients = n;
  }
  const bool lens = MrcalLens::names_a_kind(lensmodel);  // evaluated by libmrcal on a base model's plane
  if (!pinhole && !lens && lensmodel != "LENSMODEL_STEREOGRAPHIC" && opencv_coefficients == 0) {
    f.fail("lensmodel", "unsupported lens model " + quoted_for_message(lensmodel) +
                            " (fishcam reads LENSMODEL_PINHOLE, LENSMODEL_STEREOGRAPHIC, LENSMODEL_OPENCV4/5/8/12, " +
                            MrcalLens::kind_names() + ")");
  }
  // fx, fy, cx, cy[, distortion]; a lens's count is checked against its model below.
  const size_t count = 4 + opencv_coefficients;
  const auto k = f.numbers("intrinsics", count, lens ? kMaxDocumentNodes : count);
  const auto size = f.numbers("imagersize", 2, 2);
  for (int i = 0; i < 2; ++i) {
    if (!(size[i] >= 1 && size[i] <= (1 << 16)) || size[i] != std::floor(size[i])) {
      f.fail("imagersize", "expected two positive integers");
    }
  }
  CameraParameters p;
  set_focal(&p, k[0], k[1], [&](std::string_view problem) { f.fail("intrinsics", problem); });
  p.width = static_cast<int>(size[0]);
  p.height = static_cast<int>(size[1]);
  p.grid.principal_point = {k[2], k[3]};
  std::vector<std::string> notes;
  if (opencv_coefficients > 0) {
    set_radial_tangential(&p, std::vector<double>(k.begin() + 4, k.end()), k[0], [&](std::string_view problem) {
      f.fail("intrinsics", lensmodel + ": " + std::string(problem));
    });
  } else if (lens) {
    try {
      p.distortion = MrcalLensDistortion::from_numbers(lensmodel, std::vector<double>(k.begin() + 4, k.end()));
    } catch (const Error& e) {
      f.fail("intrinsics", e.what());
    }
    if (f.has("valid_intrinsics_region")) {
      notes.push_back("valid_intrinsics_region is not read (the valid domain is where the projection is one-to-one)");
    }
  }
  if (opencv_coefficients == 0) {  // LENSMODEL_PINHOLE, LENSMODEL_STEREOGRAPHIC or a lens's base model
    const std::string_view base = p.mrcal_lens() ? p.mrcal_lens()->base_model() : pinhole ? "pinhole" : "stereographic";
    p.model = make_model(base, std::span<const double>(k.data(), 1));
  }
  if (f.has("extrinsics")) p.pose = pose_from_rt_cam_ref(f.numbers("extrinsics", 6, 6));
  return {{"0", p, notes}};
}

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", x);
  return text;
}

std::string write(const CameraParameters& p) {
  double f = 0;
  std::string lensmodel;
  std::vector<double> distortion;
  if (const auto* m = std::get_if<Stereographic<double>>(&p.model)) {
    f = m->f(), lensmodel = "LENSMODEL_STEREOGRAPHIC";
  } else if (const auto* m = std::get_if<Pinhole<double>>(&p.model); m && !p.tangential_terms().any()) {
    f = m->f(), lensmodel = "LENSMODEL_PINHOLE";
  } else if (std::optional<RadialTangential> r = radial_tangential_of(p)) {
    r->d.resize(std::max<size_t>(r->d.size(), 8), 0.0);  // OPENCV8 or OPENCV12
    f = r->f, lensmodel = "LENSMODEL_OPENCV" + std::to_string(r->d.size()), distortion = r->d;
  } else {
    cannot_hold(p, CameraFormat::mrcal);
  }
  if (const MrcalLens* lens = p.mrcal_lens())
    lensmodel = lens->lensmodel(), distortion = lens->values();  // on its base model
  const std::array<double, 6> rt = p.pose ? rt_cam_ref_from_pose(*p.pose) : std::array<double, 6>{};
  std::string out = "{\n    'lensmodel':  '" + lensmodel + "',\n\n";
  out += std::string("    # intrinsics are fx,fy,cx,cy") + (distortion.empty() ? "" : ",distortion0,distortion1,....") +
         "\n";
  out += "    'intrinsics': [";
  for (double x : {f * p.grid.pixel_scale.x(), f * p.grid.pixel_scale.y(), p.grid.principal_point.x(),
                   p.grid.principal_point.y()}) {
    out += ' ', out += number(x), out += ',';
  }
  for (double x : distortion) out += ' ', out += number(x), out += ',';
  out += "],\n\n    # extrinsics are rt_fromref (rt_cam_ref)\n    'extrinsics': [";
  for (double x : rt) out += ' ', out += number(x), out += ',';
  out += "],\n\n    'imagersize': [ " + std::to_string(p.width) + ", " + std::to_string(p.height) + ",],\n}\n";
  return out;
}

}  // namespace

extern const FormatSpec mrcal_format{
    .id = CameraFormat::mrcal,
    .name = "mrcal",
    .description = "mrcal .cameramodel",
    .extensions = {".cameramodel"},
    .models = {"pinhole", "stereographic", "opencv"},
    .distortions = {{"tangential", {}}, {"mrcal_lens", {}}},
    .score = score,
    .read = read,
    .write = write,
};

}  // namespace fishcam::detail
