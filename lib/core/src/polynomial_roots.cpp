// Algebraic root tools for polynomial-type radial models: the exact fold of a
// model (first root of its derivative) and an independent theta(rho) check.
#include <Eigen/QR>
#include <unsupported/Eigen/Polynomials>

#include <algorithm>
#include <cmath>
#include <limits>

#include "fishcam/core/error.hpp"
#include "fishcam/core/radial_inverse.hpp"

namespace fishcam {
namespace {

double evaluate(std::span<const double> c, double x) {
  double r = 0;
  for (size_t i = c.size(); i-- > 0;) r = r * x + c[i];
  return r;
}

double evaluate_derivative(std::span<const double> c, double x) {
  double r = 0;
  for (size_t i = c.size(); i-- > 1;) r = r * x + double(i) * c[i];
  return r;
}

// Sum of |c_i x^i|: the scale against which a residual is "zero".
double magnitude(std::span<const double> c, double x) {
  double r = 0;
  for (size_t i = c.size(); i-- > 0;) r = r * std::abs(x) + std::abs(c[i]);
  return r;
}

// Relative: a root of size 1e-100 with an imaginary part of 1e-100 is complex.
bool is_real(const std::complex<double>& z) { return std::abs(z.imag()) <= 1e-7 * std::abs(z); }

// Root of c in [lo, hi] where c(lo) and c(hi) have opposite signs: bracketed Newton.
double refine_in_bracket(std::span<const double> c, double lo, double hi) {
  const bool increasing = evaluate(c, lo) < 0;
  double x = 0.5 * (lo + hi);
  for (int i = 0; i < 200 && hi - lo > 2 * std::numeric_limits<double>::epsilon() * hi; ++i) {
    const double f = evaluate(c, x);
    if (f == 0) return x;
    ((f < 0) == increasing ? lo : hi) = x;
    double next = x - f / evaluate_derivative(c, x);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (next == x) break;
    x = next;
  }
  return x;
}

}  // namespace

PowerSeriesFit fit_power_series(std::span<const double> x, std::span<const double> y, int first, int last) {
  if (x.size() != y.size() || first < 0 || last < first) throw Error("fit_power_series: bad arguments");
  const Eigen::Index n = Eigen::Index(x.size()), terms = last - first + 1;
  Eigen::MatrixXd design(n, terms);
  for (Eigen::Index i = 0; i < n; ++i) {
    double power = std::pow(x[size_t(i)], first);
    for (Eigen::Index j = 0; j < terms; ++j, power *= x[size_t(i)]) design(i, j) = power;
  }
  const Eigen::Map<const Eigen::VectorXd> values(y.data(), n);
  const Eigen::VectorXd c = design.colPivHouseholderQr().solve(values);
  return {std::vector<double>(c.data(), c.data() + terms), (design * c - values).cwiseAbs().maxCoeff()};
}

std::vector<std::complex<double>> polynomial_roots(std::span<const double> coefficients) {
  size_t n = coefficients.size();
  while (n > 0 && coefficients[n - 1] == 0) --n;
  if (n <= 1) return {};
  Eigen::VectorXd c(n);
  for (size_t i = 0; i < n; ++i) c[i] = coefficients[i];
  Eigen::PolynomialSolver<double, Eigen::Dynamic> solver(c);
  const auto& roots = solver.roots();
  return {roots.data(), roots.data() + roots.size()};
}

std::optional<double> first_positive_root(std::span<const double> c, double limit) {
  // Exact candidates: real eigenvalues of the companion matrix in (0, limit], each
  // polished (a bracket where the sign changes across it, else Newton: a double root
  // where the derivative only touches zero) and kept only if it is a root indeed.
  std::vector<double> candidates;
  for (const auto& z : polynomial_roots(c)) {
    if (is_real(z) && z.real() > 0 && z.real() <= limit * (1 + 1e-12)) candidates.push_back(z.real());
  }
  std::sort(candidates.begin(), candidates.end());
  std::optional<double> best;
  for (const double r : candidates) {
    const double delta = 1e-6 * r, lo = r - delta, hi = r + delta;
    double x = r;
    if (evaluate(c, lo) * evaluate(c, hi) < 0) {
      x = refine_in_bracket(c, lo, hi);
    } else {
      for (int i = 0; i < 100; ++i) {
        const double d = evaluate_derivative(c, x);
        if (d == 0) break;
        const double next = x - evaluate(c, x) / d;
        if (!(std::abs(next - r) < delta) || next == x) break;
        x = next;
      }
    }
    if (std::abs(evaluate(c, x)) <= 1e-9 * magnitude(c, x)) {
      best = std::min(x, limit);
      break;
    }
  }
  // Safety net against a real root the eigenvalues reported as complex: the first
  // sign change on a fine grid brackets a root that then gets refined exactly.
  constexpr int kScan = 4096;
  const double sign0 = evaluate(c, 0.0) > 0 ? 1.0 : -1.0;
  double previous = 0;
  for (int i = 1; i <= kScan; ++i) {
    const double x = limit * i / kScan;
    if (best && x >= *best) break;
    if (sign0 * evaluate(c, x) <= 0) return refine_in_bracket(c, previous, x);
    previous = x;
  }
  return best;
}

}  // namespace fishcam
