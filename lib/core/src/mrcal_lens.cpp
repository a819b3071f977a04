#include "fishcam/core/mrcal_lens.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string_view>

#include "fishcam/core/error.hpp"

extern "C" {  // mrcal 2.2's headers have no extern "C" of their own
#include <mrcal/mrcal.h>
}

namespace fishcam {

struct MrcalLens::Lensmodel {
  mrcal_lensmodel_t model;
  bool projects_behind = false;      // mrcal's metadata: whether rays with z <= 0 have a projection
  bool stereographic_plane = false;  // the base model (kinds()): stereographic, else pinhole
};

namespace {

constexpr std::array<MrcalLens::KindInfo, 5> kKinds = {{
    {MrcalLens::Kind::splined_stereographic, "LENSMODEL_SPLINED_STEREOGRAPHIC", "_order=O_Nx=X_Ny=Y_fov_x_deg=F",
     "stereographic"},
    {MrcalLens::Kind::cahvor, "LENSMODEL_CAHVOR", "", "pinhole"},
    {MrcalLens::Kind::cahvore, "LENSMODEL_CAHVORE", "_linearity=L", "stereographic"},
    {MrcalLens::Kind::lonlat, "LENSMODEL_LONLAT", "", "stereographic"},
    {MrcalLens::Kind::latlon, "LENSMODEL_LATLON", "", "stereographic"},
}};

std::optional<MrcalLens::Kind> kind_of(mrcal_lensmodel_type_t type) {
  switch (type) {
    case MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC:
      return MrcalLens::Kind::splined_stereographic;
    case MRCAL_LENSMODEL_CAHVOR:
      return MrcalLens::Kind::cahvor;
    case MRCAL_LENSMODEL_CAHVORE:
      return MrcalLens::Kind::cahvore;
    case MRCAL_LENSMODEL_LONLAT:
      return MrcalLens::Kind::lonlat;
    case MRCAL_LENSMODEL_LATLON:
      return MrcalLens::Kind::latlon;
    default:
      return std::nullopt;
  }
}

}  // namespace

const std::array<MrcalLens::KindInfo, 5>& MrcalLens::kinds() { return kKinds; }

bool MrcalLens::names_a_kind(const std::string& lensmodel) {
  for (const KindInfo& k : kKinds) {
    if (*k.configuration ? lensmodel.rfind(k.lensmodel, 0) == 0 : lensmodel == k.lensmodel) return true;
  }
  return false;
}

std::string MrcalLens::kind_names() {
  std::string out;
  for (const KindInfo& k : kKinds) {
    if (!out.empty()) out += ", ";
    out += k.lensmodel;
    out += k.configuration;
  }
  return out;
}

MrcalLens::MrcalLens(std::string lensmodel, std::vector<double> values)
    : lensmodel_(std::move(lensmodel)), values_(std::move(values)), parsed_(std::make_unique<Lensmodel>()) {
  std::string shown = "'";  // appended, not "'" + ...: g++ 12 warns falsely (-Wrestrict) on that
  shown.append(lensmodel_, 0, 80).push_back('\'');
  const bool parsed = mrcal_lensmodel_from_name(&parsed_->model, lensmodel_.c_str());
  const std::optional<Kind> kind = parsed ? kind_of(parsed_->model.type) : std::nullopt;
  if (!kind) throw Error(shown + " is not one of the mrcal lens models fishcam evaluates (" + kind_names() + ")");
  kind_ = *kind;
  parsed_->stereographic_plane = std::string_view(base_model()) == "stereographic";
  parsed_->projects_behind = mrcal_lensmodel_metadata(&parsed_->model).can_project_behind_camera;
  // libmrcal asserts (aborts) on configurations it does not support, and parses its
  // integers as uint16 (wrapping): checked here, and the name must be what mrcal
  // itself writes for the configuration it parsed.
  char canonical[256];
  if (!mrcal_lensmodel_name(canonical, sizeof canonical, &parsed_->model) || lensmodel_ != canonical) {
    throw Error(shown + " is not written as mrcal writes its configuration");
  }
  if (kind_ == Kind::splined_stereographic) {
    const auto& config = parsed_->model.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
    if (config.order != 2 && config.order != 3) throw Error("order must be 2 or 3 (mrcal's splines)");
    if (config.Nx < 4 || config.Ny < 4 || config.Nx > 200 || config.Ny > 200) {
      throw Error("Nx and Ny must be in [4, 200]");
    }
    if (config.fov_x_deg < 1 || config.fov_x_deg > 359) throw Error("fov_x_deg must be in [1, 359]");
  }
  if (kind_ == Kind::cahvore && !std::isfinite(parsed_->model.LENSMODEL_CAHVORE__config.linearity)) {
    throw Error(shown + ": the linearity must be a finite number");
  }
  const int count = mrcal_lensmodel_num_params(&parsed_->model) - 4;
  if (int(values_.size()) != count) {
    throw Error(lensmodel_ + " has " + std::to_string(count) + " values after fx, fy, cx, cy, got " +
                std::to_string(values_.size()));
  }
  for (double v : values_) {
    if (!std::isfinite(v)) throw Error(lensmodel_ + ": the values must be finite");
    // Every value is a small displacement or coefficient on the normalised plane
    // (mrcal's fits give |v| < 1); past kMaxValue a lens folds everywhere, and its
    // domain scan and tables take minutes to say so.
    if (!(std::abs(v) <= kMaxValue)) {
      throw Error(lensmodel_ + ": values must lie within [-" + number_for_message(kMaxValue) + ", " +
                  number_for_message(kMaxValue) + "], got " + number_for_message(v));
    }
  }
  intrinsics_ = {1, 1, 0, 0};
  intrinsics_.insert(intrinsics_.end(), values_.begin(), values_.end());
}

MrcalLens::~MrcalLens() = default;

std::shared_ptr<const MrcalLens> MrcalLens::with_zero_values(const std::string& lensmodel) {
  mrcal_lensmodel_t model;
  if (!mrcal_lensmodel_from_name(&model, lensmodel.c_str()) || !kind_of(model.type)) {
    std::string shown = "'";
    shown.append(lensmodel, 0, 80).push_back('\'');
    throw Error(shown + " is not one of the mrcal lens models fishcam evaluates (" + kind_names() + ")");
  }
  // A configuration libmrcal would assert on, or one too large to allocate, is given
  // no values: the constructor refuses its configuration before the count.
  const auto& c = model.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
  const bool spline = model.type == MRCAL_LENSMODEL_SPLINED_STEREOGRAPHIC;
  const bool sane = !spline || ((c.order == 2 || c.order == 3) && c.Nx >= 4 && c.Nx <= 200 && c.Ny >= 4 && c.Ny <= 200);
  const int count = sane ? mrcal_lensmodel_num_params(&model) - 4 : 0;
  return std::make_shared<const MrcalLens>(lensmodel, std::vector<double>(size_t(std::max(0, count)), 0.0));
}

const char* MrcalLens::base_model() const {
  for (const KindInfo& k : kKinds) {
    if (k.kind == kind_) return k.base_model;
  }
  return "";  // unreachable: kind_ comes from kKinds
}

Eigen::Vector2d MrcalLens::offset(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian) const {
  // The ray through m on the base model's plane (any length): (m, 1 - |m|^2 / 4) for the
  // stereographic one (|m| = 2 tan(theta / 2)), (m, 1) for the pinhole one.
  const bool stereographic = parsed_->stereographic_plane;
  if (jacobian && kind_ == Kind::cahvore) {  // libmrcal has no gradients for it: central differences
    const Eigen::Vector2d at = offset(m);
    for (int k = 0; k < 2; ++k) {
      const double h = 6e-6 * (1 + m.norm());  // ~ cbrt(epsilon): truncation and rounding balanced
      const Eigen::Vector2d step = h * Eigen::Vector2d::Unit(k);
      const Eigen::Vector2d plus = offset(m + step), minus = offset(m - step);
      // One-sided next to the domain's end (90 degrees), where one side has no projection.
      jacobian->col(k) = plus.allFinite() && minus.allFinite() ? Eigen::Vector2d((plus - minus) / (2 * h))
                         : plus.allFinite()                    ? Eigen::Vector2d((plus - at) / h)
                                                               : Eigen::Vector2d((at - minus) / h);
    }
    return at;
  }
  const double dz = stereographic ? -0.5 : 0.0;  // dz/dm = dz * m^T
  const mrcal_point3_t p = {{m.x(), m.y(), stereographic ? 1 - 0.25 * m.squaredNorm() : 1.0}};
  mrcal_point2_t q;
  mrcal_point3_t dq_dp[2];
  // mrcal_project returns numbers behind a model that cannot project there (CAHVORE on the
  // stereographic plane past 90 degrees): none, so the domain stops at 90 degrees.
  if ((!parsed_->projects_behind && !(p.z >= 0)) ||
      !mrcal_project(&q, jacobian ? dq_dp : nullptr, nullptr, &p, 1, &parsed_->model, intrinsics_.data())) {
    if (jacobian) jacobian->setConstant(std::numeric_limits<double>::quiet_NaN());
    return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  if (jacobian) {
    // d delta/dm = dq/dp dp/dm - I, dp/dm = [1 0; 0 1; dz m_x  dz m_y].
    for (int r = 0; r < 2; ++r) {
      const double* g = dq_dp[r].xyz;
      (*jacobian)(r, 0) = g[0] + dz * m.x() * g[2] - (r == 0);
      (*jacobian)(r, 1) = g[1] + dz * m.y() * g[2] - (r == 1);
    }
  }
  return {q.x - m.x(), q.y - m.y()};
}

Eigen::Vector2d MrcalLens::project_with_values(const Eigen::Vector3d& point, const double* values,
                                               Eigen::Matrix<double, 2, 3>* d_point, double* d_values) const {
  if (kind_ != Kind::splined_stereographic && kind_ != Kind::cahvor) {
    throw Error(lensmodel_ + ": libmrcal gives no gradients in its values");
  }
  const size_t count = values_.size();
  std::vector<double> intrinsics(4 + count);
  intrinsics[0] = intrinsics[1] = 1;
  std::copy(values, values + count, intrinsics.begin() + 4);
  const mrcal_point3_t p = {{point.x(), point.y(), point.z()}};
  mrcal_point2_t q;
  mrcal_point3_t dq_dp[2];
  std::vector<double> dq_dintrinsics(d_values ? 2 * intrinsics.size() : 0);
  if ((!parsed_->projects_behind && !(p.z > 0)) ||
      !mrcal_project(&q, d_point ? dq_dp : nullptr, d_values ? dq_dintrinsics.data() : nullptr, &p, 1, &parsed_->model,
                     intrinsics.data())) {
    return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  if (d_point) {
    for (int r = 0; r < 2; ++r) d_point->row(r) = Eigen::Vector3d(dq_dp[r].xyz[0], dq_dp[r].xyz[1], dq_dp[r].xyz[2]);
  }
  if (d_values) {
    for (size_t r = 0; r < 2; ++r) {
      std::copy_n(dq_dintrinsics.begin() + long(r * intrinsics.size() + 4), count, d_values + r * count);
    }
  }
  return {q.x, q.y};
}

std::optional<MrcalLens::PolynomialCells> MrcalLens::polynomial_cells() const {
  if (kind_ != Kind::splined_stereographic) return std::nullopt;
  const auto& config = parsed_->model.LENSMODEL_SPLINED_STEREOGRAPHIC__config;
  std::vector<double> ux(config.Nx), uy(config.Ny);
  if (!mrcal_knots_for_splined_models(ux.data(), uy.data(), &parsed_->model)) {
    throw Error("spline: libmrcal gave no knots for " + lensmodel_);
  }
  // mrcal's segment coordinate is u * cells_per_u + (N - 1) / 2 (the knots' indices);
  // a cubic segment [i, i + 1] needs knots i - 1 .. i + 2 (i = 1 .. N - 3), a quadratic
  // one [i - 1/2, i + 1/2] knots i - 1 .. i + 1 (i = 1 .. N - 2).
  PolynomialCells cells;
  cells.order = config.order;
  cells.cells_per_u = 1 / (ux[1] - ux[0]);
  const double first = config.order == 3 ? 1 : 0.5;
  cells.origin = {0.5 * (config.Nx - 1) - first, 0.5 * (config.Ny - 1) - first};
  cells.nx = config.order == 3 ? config.Nx - 3 : config.Nx - 2;
  cells.ny = config.order == 3 ? config.Ny - 3 : config.Ny - 2;
  return cells;
}

}  // namespace fishcam
