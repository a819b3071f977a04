// OCamCalib's calib_results.txt (Scaramuzza's toolbox, export_data.m): five
// blocks of numbers after '#' comments -- `pol` (count, then a0..aN: the ray of
// image radius rho is (x, y, P(rho)) in OCamCalib's frame), `invpol` (count, then
// the polynomial giving rho from the ray's elevation, world2cam's shortcut), the
// centre as "row column" from 0, the affine c, d, e, and "height width".
//
// OCamCalib's frame has x along rows, y along columns and the camera looking along
// -z: fishcam's (X, Y, Z) = (y_o, x_o, -z_o), so with q = rho (X, Y) / |(X, Y)|,
//   column = yc + q_x + e q_y,   row = xc + d q_x + c q_y:
// the ocam model with pol's coefficients, principal point (yc, xc), a = (1, c) and
// the skew xy = e, yx = d / c (CameraParameters::skew). fishcam projects with pol
// (invpol only approximates its inverse): the reader checks that invpol agrees
// with pol over the image and the writer fits invpol to pol (docs/formats.md).
#include <cmath>
#include <cstdio>
#include <sstream>

#include "format.hpp"

namespace fishcam::detail {
namespace {

constexpr std::string_view kDirectComment = "#polynomial coefficients for the DIRECT mapping function";
constexpr std::string_view kCentreComment = "starting from 0";
// invpol may miss pol's inverse by this much over the image before the file is
// called inconsistent (OCamCalib fits it to about 0.01 px).
constexpr double kInvpolTolerancePx = 0.5;
// The writer's invpol: the lowest degree that reaches this over the image.
constexpr double kInvpolFitPx = 1e-3;
constexpr int kMaxInvpolDegree = 24;

int score(const Content& c) {
  return c.text().size() < (1 << 20) && c.text().find(kDirectComment) != std::string_view::npos ? 100 : 0;
}

// rho of invpol at the ray elevation theta - pi/2 (world2cam).
double invpol_rho(const std::vector<double>& invpol, double theta) {
  const double t = theta - std::numbers::pi / 2;
  double rho = 0;
  for (size_t i = invpol.size(); i-- > 0;) rho = rho * t + invpol[i];
  return rho;
}

// The largest incidence angle of the image: its border's pixels, unprojected.
double widest_theta(const Camera& camera) {
  double widest = 0;
  const int w = camera.width(), h = camera.height();
  const auto at = [&](double u, double v) {
    Eigen::Vector3d ray;
    if (camera.unproject({u, v}, &ray)) widest = std::max(widest, std::acos(std::clamp(ray.z(), -1.0, 1.0)));
  };
  for (int i = 0; i <= 256; ++i) {
    const double u = -0.5 + w * i / 256.0, v = -0.5 + h * i / 256.0;
    at(u, -0.5), at(u, h - 0.5), at(-0.5, v), at(w - 0.5, v);
  }
  return widest;
}

// The file's lines of numbers (comments and blank lines skipped); whether the comment
// above the centre states its convention.
std::vector<std::vector<double>> number_lines(const Content& c, bool* centre_convention_stated) {
  std::vector<std::vector<double>> lines;
  *centre_convention_stated = false;
  std::istringstream in{std::string(c.text())};
  for (std::string line; std::getline(in, line);) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    if (line[line.find_first_not_of(" \t\r")] == '#') {
      if (lines.size() == 2 && line.find(kCentreComment) != std::string::npos) *centre_convention_stated = true;
      continue;
    }
    std::istringstream words(line);
    std::vector<double> numbers;
    for (std::string w; words >> w;) {
      numbers.push_back(DocFields::parse_number(w, [&](std::string_view problem) {
        throw Error(c.source() + ": data line " + std::to_string(lines.size() + 1) + ": " + quoted_for_message(w) +
                    ": " + std::string(problem));
      }));
    }
    lines.push_back(std::move(numbers));
  }
  return lines;
}

// invpol is world2cam's approximation of pol's inverse: it must agree over the image.
void check_invpol(const CameraParameters& p, const std::vector<double>& invpol) {
  const Camera camera(p);
  const double widest = widest_theta(camera);
  double worst = 0;
  for (int i = 0; i <= 1000; ++i) {
    const double theta = widest * i / 1000;
    worst = std::max(worst, std::abs(invpol_rho(invpol, theta) - camera.rho(theta)));
  }
  if (!(worst <= kInvpolTolerancePx)) {
    std::ostringstream msg;
    msg << "invpol: misses pol's inverse by " << worst << " px within the image (more than " << kInvpolTolerancePx
        << " px): the file's two polynomials describe different cameras";
    throw Error(msg.str());
  }
}

std::vector<NamedCamera> read(const Content& c) {
  const std::string& source = c.source();
  const auto fail = [&](const std::string& problem) -> void { throw Error(source + ": " + problem); };
  bool centre_convention_stated = false;
  const std::vector<std::vector<double>> lines = number_lines(c, &centre_convention_stated);
  if (lines.size() != 5) {
    fail("expected 5 blocks of numbers (pol, invpol, centre, affine c d e, image height width), got " +
         std::to_string(lines.size()));
  }
  const auto counted = [&](size_t k, const char* name) {
    const std::vector<double>& l = lines[k];
    if (l.empty() || !(l[0] >= 1 && l[0] <= 64) || l[0] != std::floor(l[0]) || l.size() != size_t(l[0]) + 1) {
      fail(std::string(name) + ": expected its count, then that many coefficients");
    }
    return std::vector<double>(l.begin() + 1, l.end());
  };
  const std::vector<double> pol = counted(0, "pol"), invpol = counted(1, "invpol");
  const auto exactly = [&](size_t k, size_t n, const char* what) {
    if (lines[k].size() != n) fail(std::string(what) + ": expected " + std::to_string(n) + " numbers");
  };
  exactly(2, 2, "centre (row column)"), exactly(3, 3, "affine (c d e)"), exactly(4, 2, "image size (height width)");
  if (!centre_convention_stated) {
    fail(
        "centre: the file does not say where its rows and columns start (OCamCalib writes \"starting from 0 (C "
        "convention)\" above it); fishcam does not guess");
  }
  if (pol.size() > 5) {
    fail("pol: " + std::to_string(pol.size()) +
         " coefficients; fishcam's ocam model holds a polynomial of degree up "
         "to 4 (a0..a4)");
  }
  const double xc = lines[2][0], yc = lines[2][1], ac = lines[3][0], ad = lines[3][1], ae = lines[3][2];
  NamedCamera named{"0", {}, {}};
  CameraParameters& p = named.camera;
  for (int i = 0; i < 2; ++i) {
    const double v = lines[4][size_t(i)];
    if (!(v >= 1 && v <= (1 << 16)) || v != std::floor(v))
      fail("image size: height and width must be positive integers");
  }
  p.height = int(lines[4][0]), p.width = int(lines[4][1]);
  std::array<double, 5> a{};
  std::copy(pol.begin(), pol.end(), a.begin());
  try {
    p.model = make_model("ocam", a);
  } catch (const Error& e) {
    fail(std::string("pol: ") + e.what());
  }
  if (!(ac > 0) || !std::isfinite(ac)) fail("affine: c must be > 0");
  p.grid.principal_point = {yc, xc};
  p.grid.pixel_scale = {1, ac};
  p.grid.skew = {ae, ad / ac};
  try {
    check_invpol(p, invpol);
  } catch (const Error& e) {
    if (std::string_view(e.what()).starts_with(source)) throw;
    fail(e.what());
  }
  return {named};
}

// invpol: least squares in the elevation t = theta - pi/2 over the image's angles,
// the lowest degree whose worst error is within kInvpolFitPx.
std::vector<double> fit_invpol(const Camera& camera, double* worst_px) {
  const double widest = std::min(widest_theta(camera), camera.domain().theta_max);
  constexpr int kSamples = 2000;
  std::vector<double> t(kSamples + 1), rho(kSamples + 1);
  for (int i = 0; i <= kSamples; ++i) {
    const double theta = widest * i / kSamples;
    t[size_t(i)] = theta - std::numbers::pi / 2, rho[size_t(i)] = camera.rho(theta);
  }
  std::vector<double> best;
  double best_error = std::numeric_limits<double>::infinity();
  for (int degree = 2; degree <= kMaxInvpolDegree; ++degree) {
    PowerSeriesFit fit = fit_power_series(t, rho, 0, degree);
    if (fit.worst < best_error) best_error = fit.worst, best = std::move(fit.coefficients);
    if (best_error <= kInvpolFitPx) break;
  }
  *worst_px = best_error;
  return best;
}

std::string numbers_line(const std::vector<double>& values, bool counted) {
  std::string out = counted ? std::to_string(values.size()) : std::string();
  for (double v : values) {
    if (!out.empty()) out += ' ';
    out += yaml_number(v);
  }
  return out + "\n\n";
}

std::string write(const CameraParameters& p) {  // a_x = 1 (format_camera), the ocam model (its list)
  const Camera camera(p);
  const double c = p.grid.pixel_scale.y(), e = p.grid.skew.xy, d = p.grid.skew.yx * c;
  std::string out = std::string(kDirectComment) + " (ocam_model.ss in MATLAB). These are used by cam2world\n\n";
  out += numbers_line(model_params(p.model), true);
  out +=
      "#polynomial coefficients for the inverse mapping function (ocam_model.invpol in MATLAB). These are used by "
      "world2cam\n\n";
  double worst = 0;
  const std::vector<double> invpol = fit_invpol(camera, &worst);
  if (!(worst <= kInvpolTolerancePx)) {
    std::ostringstream msg;
    msg << "ocamcalib: invpol (world2cam's polynomial) cannot follow pol's inverse over this image: " << worst
        << " px at best, more than " << kInvpolTolerancePx << " px";
    throw Error(msg.str());
  }
  out += numbers_line(invpol, true);
  out += "#center: \"row\" and \"column\", starting from 0 (C convention)\n\n";
  out += numbers_line({p.grid.principal_point.y(), p.grid.principal_point.x()}, false);
  out += "#affine parameters \"c\", \"d\", \"e\"\n\n";
  out += numbers_line({c, d, e}, false);
  out += "#image size: \"height\" and \"width\"\n\n";
  out += std::to_string(p.height) + " " + std::to_string(p.width) + "\n\n";
  return out;
}

}  // namespace

extern const FormatSpec ocamcalib_format{
    .id = CameraFormat::ocamcalib,
    .name = "ocamcalib",
    .description = "OCamCalib calib_results.txt",
    .extensions = {".txt"},
    .models = {"ocam"},
    .score = score,
    .read = read,
    .write = write,
    .holds = {.skew = true},
};

}  // namespace fishcam::detail
