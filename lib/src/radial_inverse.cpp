#include "fishcam/radial_inverse.hpp"

#include <numbers>
#include <sstream>

#include "fishcam/error.hpp"

namespace fishcam {

const char* to_string(ValidDomain::Limit limit) {
  switch (limit) {
    case ValidDomain::Limit::model: return "model";
    case ValidDomain::Limit::fold: return "fold";
    case ValidDomain::Limit::user: return "user";
  }
  return "?";
}

template <class Model>
ValidDomain compute_domain(const Model& model, std::optional<double> user_limit) {
  constexpr double kDeg = 180 / std::numbers::pi;
  const double slope0 = model.drho(0.0);
  if (!std::isfinite(slope0)) {  // e.g. N * kN overflows
    throw Error(std::string(Model::kName) + ": coefficients too large (drho/dtheta overflows)");
  }
  if (!(slope0 > 0)) {
    std::ostringstream msg;
    msg << Model::kName << ": rho must increase at theta = 0 (drho/dtheta(0) = " << slope0 << "); "
        << (std::is_same_v<Model, Polynomial<double>> ? "k1 must be > 0" : "f must be > 0");
    throw Error(msg.str());
  }
  ValidDomain domain{Model::kThetaLimit, 0, !Model::kLimitIsOpen, ValidDomain::Limit::model};
  if constexpr (PolynomialInTheta<Model>) {
    const std::vector<double> c = model.power_coefficients();
    std::vector<double> derivative(c.size() - 1);
    for (size_t i = 0; i + 1 < c.size(); ++i) derivative[i] = double(i + 1) * c[i + 1];
    if (const auto fold = first_positive_root(derivative, domain.theta_max); fold && *fold < domain.theta_max) {
      domain.theta_max = *fold;
      domain.closed = true;
      domain.limited_by = ValidDomain::Limit::fold;
    }
  }
  if (user_limit) {
    const double limit = *user_limit;
    const bool in_range = Model::kLimitIsOpen ? limit < Model::kThetaLimit : limit <= Model::kThetaLimit;
    if (!(limit > 0) || !in_range) {
      std::ostringstream msg;
      msg.precision(15);  // 180.0000001 must not print as 180
      msg << "theta_limit: must be in (0, " << Model::kThetaLimit * kDeg << "] degrees"
          << (Model::kLimitIsOpen ? " (exclusive)" : "") << " for " << Model::kName << ", got " << limit * kDeg;
      throw Error(msg.str());
    }
    if (limit < domain.theta_max || (limit == domain.theta_max && !domain.closed)) {
      domain = {limit, 0, true, ValidDomain::Limit::user};
    }
  }
  domain.rho_max = domain.closed ? model.rho(domain.theta_max) : std::numeric_limits<double>::infinity();
  if (domain.closed && !(domain.rho_max > 0 && std::isfinite(domain.rho_max))) {
    std::ostringstream msg;
    msg << Model::kName << ": rho(theta_max) = " << domain.rho_max << " is not a finite positive radius";
    throw Error(msg.str());
  }
  return domain;
}

namespace {

// Power coefficients of the cubic Hermite interpolant on t in [0, 1] from the end
// values v and slopes m (per unit t).
void hermite(double v0, double m0, double v1, double m1, double* c) {
  c[0] = v0;
  c[1] = m0;
  c[2] = -3 * v0 - 2 * m0 + 3 * v1 - m1;
  c[3] = 2 * v0 + m0 - 2 * v1 + m1;
}

double cubic(const double* c, double t) { return c[0] + t * (c[1] + t * (c[2] + t * c[3])); }

}  // namespace

template <class Model>
InverseTable::InverseTable(const Model& model, const ValidDomain& domain, double tolerance_px, int cells)
    : tolerance_px_(tolerance_px) {
  if (cells < 1 || !(tolerance_px > 0)) throw Error("inverse table: needs >= 1 cell and a positive tolerance");
  const double range = domain.closed ? domain.rho_max : 0.0;
  if (!(range > 0 && std::isfinite(range))) return;  // open domain: callers use the closed form
  const double step = range / cells;
  // Node values and slopes (d/dt = step * d/drho) of theta, sin(theta)/rho, cos(theta).
  struct Node {
    double theta, dtheta, s, ds, c, dc;
  };
  // At rho = 0: sin(theta)/rho -> 1/rho'(0), slope -rho''(0) / (2 rho'(0)^3).
  const double a = model.drho(0.0), delta = 1e-4;
  const double second = (model.drho(delta) - model.drho(-delta)) / (2 * delta);
  std::vector<Node> nodes(cells + 1);
  for (int i = 0; i <= cells; ++i) {
    const double rho = i == cells ? domain.rho_max : step * i;
    const double theta = solve_theta(model, rho, domain);
    const double dtheta = 1 / model.drho(theta);  // infinite at a fold
    const double sin = std::sin(theta), cos = std::cos(theta);
    Node& n = nodes[i];
    n.theta = theta, n.dtheta = step * dtheta;
    n.c = cos, n.dc = -step * sin * dtheta;
    n.s = rho > 0 ? sin / rho : 1 / a;
    n.ds = rho > 0 ? step * (cos * dtheta * rho - sin) / (rho * rho) : -step * second / (2 * a * a * a);
  }
  theta_coefficients_.resize(4 * static_cast<size_t>(cells));
  ray_coefficients_.resize(8 * static_cast<size_t>(cells));
  constexpr int kSamples = 8;
  for (int i = 0; i < cells; ++i) {
    double* ct = &theta_coefficients_[4 * static_cast<size_t>(i)];
    double* cr = &ray_coefficients_[8 * static_cast<size_t>(i)];
    const Node &n0 = nodes[i], &n1 = nodes[i + 1];
    hermite(n0.theta, n0.dtheta, n1.theta, n1.dtheta, ct);
    hermite(n0.s, n0.ds, n1.s, n1.ds, cr);
    hermite(n0.c, n0.dc, n1.c, n1.dc, cr + 4);
    double worst = 0, worst_ray = 0;
    for (int k = 0; k <= kSamples; ++k) {
      const double t = double(k) / kSamples, rho = step * (i + t);
      const double theta_error = std::abs(model.rho(cubic(ct, t)) - rho);
      // The ray's angle error, from its components against the exact angle, in px.
      const double exact = solve_theta(model, rho, domain);
      const double ray_error = std::max(std::abs(cubic(cr, t) * rho - std::sin(exact)),
                                        std::abs(cubic(cr + 4, t) - std::cos(exact))) * model.drho(exact);
      worst = std::isfinite(theta_error) ? std::max(worst, theta_error) : INFINITY;
      worst_ray = std::isfinite(ray_error) ? std::max(worst_ray, ray_error) : INFINITY;
    }
    if (worst > tolerance_px || worst_ray > tolerance_px) {
      ct[0] = cr[0] = std::numeric_limits<double>::quiet_NaN();
      ++fallback_cells_;
    } else {
      worst_error_px_ = std::max(worst_error_px_, worst);
      worst_ray_error_px_ = std::max(worst_ray_error_px_, worst_ray);
    }
  }
  cells_ = cells;
  inverse_step_ = 1 / step;
  last_ = cells;
}

#define FISHCAM_INSTANTIATE(Model)                                                                   \
  template ValidDomain compute_domain<Model>(const Model&, std::optional<double>);                 \
  template InverseTable::InverseTable(const Model&, const ValidDomain&, double, int);
FISHCAM_INSTANTIATE(Polynomial<double>)
FISHCAM_INSTANTIATE(Equidistant<double>)
FISHCAM_INSTANTIATE(Stereographic<double>)
FISHCAM_INSTANTIATE(Pinhole<double>)
FISHCAM_INSTANTIATE(KannalaBrandt<double>)
#undef FISHCAM_INSTANTIATE

}  // namespace fishcam
