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

template <class Model>
InverseTable::InverseTable(const Model& model, const ValidDomain& domain, double tolerance_px, int cells)
    : tolerance_px_(tolerance_px) {
  if (cells < 1 || !(tolerance_px > 0)) throw Error("inverse table: needs >= 1 cell and a positive tolerance");
  const double range = domain.closed ? domain.rho_max : 0.0;
  if (!(range > 0 && std::isfinite(range))) return;  // open domain: callers use the solver
  const double step = range / cells;
  std::vector<double> theta(cells + 1), slope(cells + 1);
  for (int i = 0; i <= cells; ++i) {
    const double rho = i == cells ? domain.rho_max : step * i;
    theta[i] = solve_theta(model, rho, domain);
    slope[i] = step / model.drho(theta[i]);  // dtheta/dt with t the cell coordinate
  }
  coefficients_.resize(4 * static_cast<size_t>(cells));
  constexpr int kSamples = 8;
  for (int i = 0; i < cells; ++i) {
    double* c = &coefficients_[4 * static_cast<size_t>(i)];
    const double t0 = theta[i], t1 = theta[i + 1], m0 = slope[i], m1 = slope[i + 1];
    c[0] = t0;
    c[1] = m0;
    c[2] = -3 * t0 - 2 * m0 + 3 * t1 - m1;
    c[3] = 2 * t0 + m0 - 2 * t1 + m1;
    double worst = 0;
    for (int s = 0; s <= kSamples; ++s) {
      const double t = double(s) / kSamples;
      const double rho = step * (i + t);
      const double error = std::abs(model.rho(c[0] + t * (c[1] + t * (c[2] + t * c[3]))) - rho);
      worst = std::isfinite(error) ? std::max(worst, error) : std::numeric_limits<double>::infinity();
    }
    if (worst > tolerance_px) {
      c[0] = std::numeric_limits<double>::quiet_NaN();
      ++fallback_cells_;
    } else {
      worst_error_px_ = std::max(worst_error_px_, worst);
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
