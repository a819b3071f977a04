#include "fishcam/fit/fit.hpp"
#include "fishcam/core/error.hpp"
#include "fishcam/core/parallel.hpp"
#include "fishcam/fit/calibration.hpp"

#include <nlohmann/json.hpp>

#include "ceres_support.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>

namespace fishcam {
namespace {

// A converted camera keeps its source's calibration record's observed angles (the
// camera frame is the same) but not the covariance, which belongs to the source's
// parameters.
void drop_covariance(CameraParameters* p) {
  if (p->calibration) p->calibration->covariance.resize(0, 0);
}

// A fitted radial model replaces the whole projection: the plane distortion and the skew go.
void drop_non_radial(CameraParameters* p) {
  p->distortion = NoPlaneDistortion{};
  p->grid.skew = {};
}

constexpr double kDeg = 180 / std::numbers::pi;

double theta_of(const Eigen::Vector3d& ray) { return std::atan2(ray.head<2>().norm(), ray.z()); }

// Residuals of a chunk of samples, for Ceres: projected minus observed pixel.
template <template <typename> class Model>
struct ChunkResidual {
  std::span<const Correspondence> samples;
  int params;
  double ax;

  template <typename T>
  bool operator()(T const* const* p, T* residuals) const {
    const Model<T> m = detail::model_from_block<Model>(p[0], params);
    const T mapping[4] = {p[1][0], p[1][1], T(ax), p[2][0]};
    for (size_t i = 0; i < samples.size(); ++i) {
      const T point[3] = {T(samples[i].ray.x()), T(samples[i].ray.y()), T(samples[i].ray.z())};
      T pixel[2];
      project_radial(m, mapping, point, pixel);
      residuals[2 * i] = pixel[0] - samples[i].pixel.x();
      residuals[2 * i + 1] = pixel[1] - samples[i].pixel.y();
    }
    return true;
  }
};

// Ceres on the full pixel error: the model's parameters and the freed ones.
// Returns the final cost.
template <template <typename> class Model>
double refine(std::span<const Correspondence> samples, int params, double ax, std::vector<double>* model,
              Eigen::Vector2d* center, double* ay, const FitOptions& options) {
  ceres::Problem problem;
  constexpr size_t kChunk = 512;
  for (size_t begin = 0; begin < samples.size(); begin += kChunk) {
    const auto chunk = samples.subspan(begin, std::min(kChunk, samples.size() - begin));
    auto* cost =
        new ceres::DynamicAutoDiffCostFunction<ChunkResidual<Model>, 8>(new ChunkResidual<Model>{chunk, params, ax});
    cost->AddParameterBlock(params);
    cost->AddParameterBlock(2);
    cost->AddParameterBlock(1);
    cost->SetNumResiduals(static_cast<int>(2 * chunk.size()));
    problem.AddResidualBlock(cost, nullptr, model->data(), center->data(), ay);
  }
  detail::bound_model_block<Model>(&problem, model->data(), params);
  if (!options.fit_center) problem.SetParameterBlockConstant(center->data());
  if (!options.fit_aspect) problem.SetParameterBlockConstant(ay);
  ceres::Solver::Summary summary;
  ceres::Solve(detail::solver_options(ceres::DENSE_NORMAL_CHOLESKY), &problem, &summary);
  if (!summary.IsSolutionUsable()) throw Error("fit: the least-squares solve failed: " + summary.message);
  return summary.final_cost;
}

// Linear least squares of rho(theta) = sum_j p_j g_j(theta) for a fixed principal
// point and pixel scale (exact for that case). With e the ray's azimuth direction
// and a = (a_x, a_y), the pixel error |c + a.(rho e) - q|^2 is w (rho - t)^2 + const
// with w = |a.e|^2 and t = (q - c).(a.e) / w.
template <template <typename> class Model>
std::vector<double> linear_fit(std::span<const Correspondence> samples, int k, const CameraParameters& start,
                               std::string_view name) {
  const Eigen::Vector2d c = start.grid.principal_point, a = start.grid.pixel_scale;
  Eigen::MatrixXd design(samples.size(), k);
  Eigen::VectorXd target(samples.size());
  std::vector<double> g(k);
  for (size_t i = 0; i < samples.size(); ++i) {
    const Eigen::Vector3d& ray = samples[i].ray;
    const double chi = ray.head<2>().norm();
    Model<double>::basis(theta_of(ray), k, g.data());
    if (chi == 0) {  // on the axis: rho = 0 carries no information about the shape
      design.row(i).setZero();
      target[i] = 0;
      continue;
    }
    const Eigen::Vector2d ae = a.cwiseProduct(ray.head<2>() / chi);
    const double w = ae.squaredNorm(), sw = std::sqrt(w);
    for (int j = 0; j < k; ++j) design(i, j) = sw * g[j];
    target[i] = sw * (samples[i].pixel - c).dot(ae) / w;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(design);
  if (qr.rank() < k)
    throw Error("fit: the samples do not determine the " + std::string(name) + " model (degenerate data)");
  const Eigen::VectorXd p = qr.solve(target);
  return Model<double>::from_basis(p.data(), k);
}

template <template <typename> class Model>
std::vector<double> fit_params(std::span<const Correspondence> samples, const ModelSpec& spec,
                               const CameraParameters& start, const FitOptions& options, Eigen::Vector2d* center,
                               double* ay) {
  const double ax = start.grid.pixel_scale.x();
  if constexpr (LinearInParams<Model<double>>) {
    const int k = Model<double>::kParamNames.empty() ? spec.order : int(Model<double>::kParamNames.size());
    std::vector<double> params = linear_fit<Model>(samples, k, start, spec.name);
    if (options.fit_center || options.fit_aspect) refine<Model>(samples, k, ax, &params, center, ay, options);
    return params;
  } else {
    // Non-linear in its shape parameters: Ceres from each of the model's starts
    // (scaled by the best equidistant focal length), the lowest cost wins.
    const int k = int(Model<double>::kParamNames.size());
    const double f = linear_fit<Equidistant>(samples, 1, start, spec.name)[0];
    double best_cost = std::numeric_limits<double>::infinity();
    std::vector<double> best;
    Eigen::Vector2d best_center = *center;
    double best_ay = *ay;
    for (std::vector<double> params : Model<double>::fit_starts(f)) {
      Eigen::Vector2d c = *center;
      double a = *ay;
      const double cost = refine<Model>(samples, k, ax, &params, &c, &a, options);
      if (cost < best_cost) best_cost = cost, best = params, best_center = c, best_ay = a;
    }
    if (best.empty()) throw Error("fit: no start of the " + spec.name + " model converged");
    *center = best_center, *ay = best_ay;
    return best;
  }
}

}  // namespace

ModelSpec parse_model_spec(std::string_view full_text) {
  ModelSpec spec;
  if (full_text.starts_with("LENSMODEL_")) {
    const std::string lensmodel(full_text);
    if (!lensmodel.starts_with("LENSMODEL_SPLINED_STEREOGRAPHIC")) {
      throw Error("model " + quoted_for_message(lensmodel) +
                  ": of mrcal's lens models fishcam calibrates LENSMODEL_SPLINED_STEREOGRAPHIC_order=O_Nx=X_Ny=Y_"
                  "fov_x_deg=F (OPENCV8 is opencv+tangential, OPENCV12 opencv+thin-prism)");
    }
    std::shared_ptr<const MrcalLens> lens;
    try {
      lens = MrcalLens::with_zero_values(lensmodel);
    } catch (const Error& e) {
      throw Error("model " + quoted_for_message(lensmodel) + ": " + e.what());
    }
    // f, the values, cx, cy, a_y and the boards' motion: what the covariance holds.
    if (lens->values().size() + 10 > size_t(CalibrationRecord::kMaxCovarianceRows)) {
      throw Error("model " + quoted_for_message(lensmodel) + ": " + std::to_string(lens->values().size() / 2) +
                  " knots; a calibration solves at most " +
                  std::to_string((CalibrationRecord::kMaxCovarianceRows - 10) / 2) + " (Nx * Ny)");
    }
    spec.name = lens->base_model();
    spec.mrcal_lens = lensmodel;
    return spec;
  }
  const auto plus = full_text.find('+');
  const std::string_view text = full_text.substr(0, plus);
  if (plus != std::string_view::npos) {
    const std::string_view terms = full_text.substr(plus + 1);
    if (terms == "tangential") {
      spec.tangential_terms = 2;
    } else if (terms == "thin-prism") {
      spec.tangential_terms = 6;
    } else {
      throw Error("model " + quoted_for_message(std::string(full_text)) +
                  ": after '+' expected tangential (p1, p2) or thin-prism (p1, p2, s1..s4)");
    }
  }
  const auto colon = text.find(':');
  spec.name = std::string(text.substr(0, colon));
  if (colon != std::string_view::npos) {
    const bool ordered =
        with_model_class(spec.name, []<template <typename> class Model>() { return takes_order<Model>; });
    if (!ordered) throw Error("model " + quoted_for_message(std::string(text)) + ": only polynomial takes an order");
    const std::string order(text.substr(colon + 1));
    size_t used = 0;
    int n = 0;
    try {
      n = std::stoi(order, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != order.size() || n < 1 || n > kMaxFittedPolynomialOrder) {
      throw Error("model " + quoted_for_message(std::string(text)) + ": order must be 1.." +
                  std::to_string(kMaxFittedPolynomialOrder));
    }
    spec.order = n;
  }
  check_model_name(spec.name);
  const bool takes_terms = with_model_class(
      spec.name, []<template <typename> class Model>() { return TakesTangentialTerms<Model<double>>; });
  if (spec.tangential_terms > 0 && !takes_terms) {
    throw Error("model " + quoted_for_message(std::string(full_text)) + ": " + spec.name +
                " has no undistorted plane for tangential terms (pinhole, opencv and mei have)");
  }
  return spec;
}

namespace {

void check_radial_spec(const ModelSpec& spec, std::string_view what) {
  if (!spec.mrcal_lens.empty()) {
    throw Error(std::string(what) + ": " + spec.mrcal_lens +
                " is solved by calibrate only (fit and convert give radial models)");
  }
  if (spec.tangential_terms > 0) {
    throw Error(std::string(what) + ": " + spec.name +
                "'s tangential terms are solved by calibrate only (fit and convert give radial models)");
  }
}

}  // namespace

std::vector<Correspondence> sample_image(const Camera& camera, int step, int offset, std::optional<double> max_theta) {
  if (step < 1 || offset < 0) throw Error("sample_image: step must be >= 1 and offset >= 0");
  // Huge images: a coarser grid, so at most kMaxSamples are held (65536^2 px at
  // step 4 would be 10 GB of samples).
  constexpr double kMaxSamples = 1 << 22;
  const double grid = (double(camera.width()) / step) * (double(camera.height()) / step);
  if (grid > kMaxSamples) step = int(std::ceil(step * std::sqrt(grid / kMaxSamples)));
  std::vector<Correspondence> out;
  for (int v = offset; v < camera.height(); v += step) {
    for (int u = offset; u < camera.width(); u += step) {
      Eigen::Vector3d ray;
      if (!camera.unproject({double(u), double(v)}, &ray)) continue;
      if (max_theta && theta_of(ray) > *max_theta) continue;
      out.push_back({ray, {double(u), double(v)}});
    }
  }
  return out;
}

CameraParameters fit_camera(std::span<const Correspondence> samples, const ModelSpec& spec,
                            const CameraParameters& start, const FitOptions& options) {
  check_radial_spec(spec, "fit");
  const int k = with_model_class(spec.name, [&]<template <typename> class Model>() {
    return Model<double>::kParamNames.empty() ? spec.order : int(Model<double>::kParamNames.size());
  });
  if (samples.size() < size_t(2 * k + 3)) {
    throw Error("fit: " + std::to_string(samples.size()) + " samples cannot determine a " + spec.name + " model");
  }
  // A model whose domain ends at a fixed angle below 180 deg (pinhole: 90) cannot
  // fit rays at or past it: a trait of the model class, not its name.
  with_model_class(spec.name, [&]<template <typename> class Model>() {
    if constexpr (requires { Model<double>::theta_limit(); }) {
      constexpr double limit = Model<double>::theta_limit();
      if constexpr (limit < std::numbers::pi) {
        for (const auto& s : samples) {
          if (!(std::atan2(s.ray.head<2>().norm(), s.ray.z()) < limit)) {
            char degrees[16];
            std::snprintf(degrees, sizeof degrees, "%g", limit * kDeg);
            throw Error("fit: a " + spec.name + " model cannot see rays at or past " + degrees +
                        " deg (limit max_angle below " + degrees + ")");
          }
        }
      }
    }
  });
  Eigen::Vector2d center = start.grid.principal_point;
  double ay = start.grid.pixel_scale.y();
  std::vector<double> params = with_model_class(spec.name, [&]<template <typename> class Model>() {
    return fit_params<Model>(samples, spec, start, options, &center, &ay);
  });
  CameraParameters fitted = start;
  fitted.grid.principal_point = center;
  fitted.grid.pixel_scale.y() = ay;
  fitted.model = make_model(spec.name, params);
  drop_non_radial(&fitted);  // the fit is radial: what it cannot represent is its residual
  fitted.theta_limit.reset();
  drop_covariance(&fitted);
  try {
    Camera check(fitted);
  } catch (const Error& e) {
    throw Error(std::string("fit: the best ") + spec.name + " model is not a valid camera: " + e.what());
  }
  return fitted;
}

CameraParameters paper_camera(const Camera& source, const ModelSpec& spec) {
  check_radial_spec(spec, "the paper's method");
  if (!model_has_paper_form(spec.name)) {
    throw Error("the paper's method (eqs. 13-14) defines equidistant and stereographic models only, not " + spec.name);
  }
  // The image's half width at half the horizontal field of view.
  const double rho = source.width() / 2.0;
  const double theta = source.field_of_view_deg().horizontal / 2 / kDeg;
  CameraParameters p = source.parameters();
  drop_non_radial(&p);
  p.theta_limit.reset();
  drop_covariance(&p);
  p.model = with_model_class(spec.name, [&]<template <typename> class Model>() -> RadialModel {
    if constexpr (has_paper_form<Model>) {
      return Model<double>::from_paper(rho, theta);
    } else {
      throw Error("unreachable: " + spec.name + " has no paper form");
    }
  });
  return p;
}

ErrorReport reprojection_errors(const Camera& camera, std::span<const Correspondence> samples) {
  ErrorReport report;
  std::vector<double> errors;
  errors.reserve(samples.size());
  const double theta_max = camera.domain().theta_max;
  const int bins = std::max(1, int(std::ceil(theta_max * kDeg / 10)));
  std::vector<double> sum2(bins, 0), worst(bins, 0);
  std::vector<long> counts(bins, 0);
  double sum2_all = 0, sum2_below = 0;
  for (const auto& s : samples) {
    Eigen::Vector2d pixel;
    if (!camera.project(s.ray, &pixel)) {
      ++report.unprojectable;
      continue;
    }
    const double e = (pixel - s.pixel).norm(), theta = theta_of(s.ray);
    errors.push_back(e);
    sum2_all += e * e;
    const int bin = std::min(bins - 1, int(theta * kDeg / 10));
    sum2[bin] += e * e, worst[bin] = std::max(worst[bin], e), ++counts[bin];
    if (theta < std::numbers::pi / 2) {
      sum2_below += e * e;
      report.max_below_90_px = std::max(report.max_below_90_px, e);
      ++report.samples_below_90;
    }
  }
  report.samples = static_cast<long>(errors.size());
  if (errors.empty()) return report;
  report.rms_px = std::sqrt(sum2_all / double(errors.size()));
  report.max_px = *std::max_element(errors.begin(), errors.end());
  const size_t p99 = std::min(errors.size() - 1, size_t(std::ceil(0.99 * double(errors.size()))) - 1);
  std::nth_element(errors.begin(), errors.begin() + p99, errors.end());
  report.p99_px = errors[p99];
  if (report.samples_below_90) report.rms_below_90_px = std::sqrt(sum2_below / double(report.samples_below_90));
  for (int b = 0; b < bins; ++b) {
    if (!counts[b]) continue;
    report.by_angle.push_back({10.0 * b, std::min(10.0 * (b + 1), theta_max * kDeg), counts[b],
                               std::sqrt(sum2[b] / double(counts[b])), worst[b]});
  }
  return report;
}

ProjectionDiff projection_diff(const Camera& a, const Camera& b, int step, bool fit_rotation) {
  ProjectionDiffOptions options;
  options.step = step, options.fit_rotation = fit_rotation;
  return projection_diff(a, b, options);
}

ProjectionDiff projection_diff(const Camera& a, const Camera& b, const ProjectionDiffOptions& options) {
  std::vector<Correspondence> samples;
  for (const auto& s : sample_image(a, options.step, options.step / 2)) {
    if (!options.region || options.region(s.pixel, s.ray)) samples.push_back(s);
  }
  std::vector<double> weights(samples.size(), 1.0);
  if (options.weigh_by_uncertainty) {
    for (size_t i = 0; i < samples.size(); ++i) {
      Eigen::Vector2d q;
      const double sa = projection_uncertainty(a, samples[i].pixel, std::nullopt);
      const double sb = b.project(samples[i].ray, &q) ? projection_uncertainty(b, q, std::nullopt) : 0.0;
      weights[i] = 1 / std::max(sa * sa + sb * sb, 1e-12);
      if (!std::isfinite(weights[i])) weights[i] = 0;
    }
  }
  ProjectionDiff diff;
  // Residuals (and their Jacobians in a small left rotation w) of the samples B
  // sees inside its image, scaled by the square roots of their weights.
  auto residuals = [&](const Eigen::Matrix3d& r, Eigen::MatrixXd* jacobian, std::vector<double>* used_weights) {
    std::vector<Eigen::Vector2d> out;
    std::vector<Eigen::Matrix<double, 2, 3>> rows;
    for (size_t i = 0; i < samples.size(); ++i) {
      const auto& s = samples[i];
      Eigen::Vector2d q;
      Eigen::Matrix<double, 2, 3> j;
      const Eigen::Vector3d rotated = r * s.ray;
      if (!b.project(rotated, &q, &j)) continue;
      if (!(q.x() >= -0.5 && q.y() >= -0.5 && q.x() < b.width() - 0.5 && q.y() < b.height() - 0.5)) continue;
      out.push_back(q - s.pixel);
      if (used_weights) used_weights->push_back(weights[i]);
      // d q / d w for a small rotation w applied on the left: J * (-[r ray]x).
      Eigen::Matrix3d cross;
      cross << 0, -rotated.z(), rotated.y(), rotated.z(), 0, -rotated.x(), -rotated.y(), rotated.x(), 0;
      rows.push_back(-std::sqrt(weights[i]) * j * cross);
    }
    if (jacobian) {
      jacobian->resize(long(2 * rows.size()), 3);
      for (size_t i = 0; i < rows.size(); ++i) jacobian->block<2, 3>(long(2 * i), 0) = rows[i];
    }
    return out;
  };
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  for (int iteration = 0; options.fit_rotation && iteration < 20; ++iteration) {  // Gauss-Newton on the rotation
    Eigen::MatrixXd jacobian;
    std::vector<double> w;
    const auto e = residuals(r, &jacobian, &w);
    if (e.size() < 10) break;
    Eigen::VectorXd rhs(long(2 * e.size()));
    for (size_t i = 0; i < e.size(); ++i) rhs.segment<2>(long(2 * i)) = std::sqrt(w[i]) * e[i];
    const Eigen::Vector3d step = -(jacobian.transpose() * jacobian).ldlt().solve(jacobian.transpose() * rhs);
    r = Eigen::AngleAxisd(step.norm(),
                          step.norm() > 0 ? Eigen::Vector3d(step.normalized()) : Eigen::Vector3d::UnitX()) *
        r;
    if (step.norm() < 1e-15) break;
  }
  const auto e = residuals(r, nullptr, nullptr);
  if (e.empty()) {
    throw Error(options.region ? "diff: no pixel of the region is valid in both cameras"
                               : "diff: the two cameras share no pixels");
  }
  double sum2 = 0;
  for (const auto& v : e) sum2 += v.squaredNorm(), diff.max_px = std::max(diff.max_px, v.norm());
  diff.pixels = long(e.size());
  diff.rms_px = std::sqrt(sum2 / double(e.size()));
  diff.rotation = r;
  return diff;
}

const std::vector<std::string>& conversion_method_names() {
  static const std::vector<std::string> names = {"lsq", "paper"};
  return names;
}

void check_conversion_method(std::string_view name) {
  const auto& names = conversion_method_names();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    throw Error("method: expected " + choices_for_message(names) + ", got " + quoted_for_message(name));
  }
}

namespace {

// The error no radial model can avoid, about the fitted camera's principal point and
// pixel scale: the best free-form rho(theta) (per 0.25-degree band of theta, a line in
// theta fitted to the samples' radial offsets along their rays' azimuths) leaves each
// sample's offset across its azimuth and its radial offset from that line.
Conversion::NonRadial non_radial_floor(std::span<const Correspondence> samples, const CameraParameters& fitted) {
  constexpr double kBand = 0.25 / kDeg;
  struct Sample {
    int band;
    double theta, along, across;
    Eigen::Vector2d direction;
  };
  std::vector<Sample> kept;
  for (const auto& s : samples) {
    const double chi = s.ray.head<2>().norm();
    if (!(chi > 0)) continue;
    const Eigen::Vector2d e = s.ray.head<2>() / chi;
    const Eigen::Vector2d q = (s.pixel - fitted.grid.principal_point).cwiseQuotient(fitted.grid.pixel_scale);
    const double theta = std::atan2(chi, s.ray.z());
    kept.push_back({int(theta / kBand), theta, q.dot(e), e.x() * q.y() - e.y() * q.x(), e});
  }
  std::map<int, std::array<double, 5>> sums;  // n, sum theta, sum theta^2, sum along, sum theta along
  for (const Sample& s : kept) {
    auto& b = sums[s.band];
    b[0] += 1, b[1] += s.theta, b[2] += s.theta * s.theta, b[3] += s.along, b[4] += s.theta * s.along;
  }
  Conversion::NonRadial out;
  double sum2 = 0;
  for (const Sample& s : kept) {
    const auto& b = sums[s.band];
    const double n = b[0], det = n * b[2] - b[1] * b[1];
    const double slope = n >= 3 && det > 1e-30 * n * n ? (n * b[4] - b[1] * b[3]) / det : 0;
    const double rho = (b[3] - slope * b[1]) / n + slope * s.theta;
    const Eigen::Vector2d normal(-s.direction.y(), s.direction.x());
    const Eigen::Vector2d error = (s.along - rho) * s.direction + s.across * normal;
    const double d = error.cwiseProduct(fitted.grid.pixel_scale).norm();
    sum2 += d * d;
    out.max_px = std::max(out.max_px, d);
    ++out.samples;
  }
  if (out.samples > 0) out.rms_px = std::sqrt(sum2 / double(out.samples));
  return out;
}

}  // namespace

Conversion convert_camera(const Camera& source, const ModelSpec& model, std::string_view method,
                          std::optional<double> max_theta, const FitOptions& options) {
  check_conversion_method(method);
  if (max_theta && !(*max_theta > 0 && *max_theta <= std::numbers::pi)) {
    throw Error("max_angle: must be in (0, 180] degrees");
  }
  Conversion out;
  if (method == "paper") {
    if (options.fit_center || options.fit_aspect) throw Error("fit_center/fit_aspect apply to the lsq method only");
    out.camera = paper_camera(source, model);
  } else {
    FitOptions fit_options = options;
    if (!source.radial()) fit_options.fit_center = fit_options.fit_aspect = true;
    out.center_and_aspect_fitted = fit_options.fit_center && fit_options.fit_aspect;
    // Every 4th pixel, weighted as images are (per pixel).
    out.camera = fit_camera(sample_image(source, 4, 1, max_theta), model, source.parameters(), fit_options);
  }
  const Camera result(out.camera);
  const auto evaluation = sample_image(source, 2, 0, max_theta);  // denser than the fit saw
  out.report = reprojection_errors(result, evaluation);
  for (const auto& s : evaluation) {
    out.widest_theta = std::max(out.widest_theta, std::atan2(s.ray.head<2>().norm(), s.ray.z()));
  }
  if (!source.radial()) out.non_radial = non_radial_floor(evaluation, out.camera);
  return out;
}

std::vector<float> reprojection_error_map(const Camera& source, const Camera& fitted) {
  if (source.width() != fitted.width() || source.height() != fitted.height()) {
    throw Error("error map: the fitted camera's image size differs from the source's");
  }
  const size_t w = size_t(source.width()), h = size_t(source.height());
  std::vector<float> map(w * h, std::numeric_limits<float>::quiet_NaN());
  parallel_for(int(h), [&](int first, int end) {
    for (size_t v = size_t(first); v < size_t(end); ++v) {
      for (size_t u = 0; u < w; ++u) {
        const Eigen::Vector2d pixel{double(u), double(v)};
        Eigen::Vector3d ray;
        Eigen::Vector2d q;
        if (source.unproject(pixel, &ray) && fitted.project(ray, &q)) map[v * w + u] = float((q - pixel).norm());
      }
    }
  });
  return map;
}

std::string fit_report_json(const CameraParameters& fitted, const ErrorReport& r) {
  nlohmann::json bins = nlohmann::json::array();
  for (const auto& b : r.by_angle) {
    bins.push_back({{"theta_from_deg", b.theta_from_deg},
                    {"theta_to_deg", b.theta_to_deg},
                    {"samples", b.samples},
                    {"rms_px", b.rms_px},
                    {"max_px", b.max_px}});
  }
  return nlohmann::json{
      {"samples", r.samples},
      {"unprojectable", r.unprojectable},
      {"rms_px", r.rms_px},
      {"p99_px", r.p99_px},
      {"max_px", r.max_px},
      {"below_90_deg", {{"samples", r.samples_below_90}, {"rms_px", r.rms_below_90_px}, {"max_px", r.max_below_90_px}}},
      {"by_angle", bins},
      {"model", model_name(fitted.model)},
      {"parameters", model_params(fitted.model)},
      {"principal_point", {fitted.grid.principal_point.x(), fitted.grid.principal_point.y()}},
      {"pixel_scale", {fitted.grid.pixel_scale.x(), fitted.grid.pixel_scale.y()}}}
      .dump();
}

}  // namespace fishcam
