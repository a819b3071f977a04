// The camera's middle part: a displacement of the radial model's undistorted plane.
// A camera is three parts applied in turn (docs/architecture.md):
//   pixel = PixelGrid( f (m + delta(m)) ),   m on the radial model's plane,
// the radial model (model_registry.hpp) giving m and f, a plane distortion (this list)
// delta, and the pixel grid (principal point, pixel scale, skew: pixel_grid.hpp)
// the pixel. Every plane distortion is one class here; everything that depends on
// "which plane distortions exist" follows from PlaneDistortionRegistry below: the
// PlaneDistortion variant, name lookup, the one serialisation of a part's numbers
// (Python pickling and cache keys, file round-trip checks), the formats' checks of
// what they hold and the every-distortion tests.
//
// A part P provides (as NoPlaneDistortion below shows):
//   static constexpr std::string_view kName;    its name in files, messages and Python
//   std::string configuration() const;         what selects it beyond its numbers ("" or mrcal's lensmodel)
//   std::vector<double> values() const;        its numbers, in the order of
//   std::vector<std::string> parameter_names() const;  (field names: "p1", "values[3]")
//   static P from_numbers(std::string_view configuration, std::vector<double> values);  throws Error
//   bool any() const;                           whether it displaces anything (false: the camera is radial)
//   std::string description() const;           for messages: "tangential terms", "mrcal's LENSMODEL_CAHVOR"
//   std::vector<std::string> base_models() const;  the radial models whose plane it displaces
//   std::string invalid() const;               "" or what is wrong with its numbers
//   Eigen::Vector2d offset(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian = nullptr) const;
//                                               delta(m), with d delta / dm on request; NaN where it has none
//   std::optional<double> evaluation_end(const PlaneRadius& radius, double theta_max) const;
//   std::string evaluation_problem(const PlaneRadius& radius, double theta_max) const;
//                                               for a part evaluated by another library that reports
//                                               its failures on standard error (libmrcal): called only
//                                               when the camera's scans made it say something; the
//                                               largest theta <= theta_max up to which it evaluates
//                                               without a word (nullopt: not even just inside), and ""
//                                               or the refusal when it still speaks inside the domain.
//                                               Parts computed here: theta_max and "".
//
// How to add a plane distortion (3 steps):
//   1. Write its class with the members above in its own header (as tangential.hpp)
//      and add it to PlaneDistortionRegistry below: one line. The camera projects,
//      unprojects, finds its fold and bounds its reach through offset() alone.
//   2. Give it an example camera in lib/testing/include/fishcam/testing/test_support.hpp
//      (distortion_examples()): the every-distortion tests fail until it has one.
//   3. Document its formula in docs/conventions.md and declare it in the formats that
//      hold it (FormatSpec::distortions, lib/io/src/formats/); the fishcam JSON
//      writer and reader do not compile until they handle it. A float-kernel form
//      for the augmentation (lib/augment/src/kernel_source.cpp, kernel_plane_form) is
//      optional: without one, warps from such a camera take the exact path.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "fishcam/core/mrcal_lens.hpp"
#include "fishcam/core/tangential.hpp"

namespace fishcam {

// The radius of the radial model's undistorted plane at incidence angle theta.
using PlaneRadius = std::function<double(double theta)>;

// No displacement: rho(theta) is the whole projection.
struct NoPlaneDistortion {
  static constexpr std::string_view kName = "none";
  std::string configuration() const { return ""; }
  std::vector<double> values() const { return {}; }
  std::vector<std::string> parameter_names() const { return {}; }
  static NoPlaneDistortion from_numbers(std::string_view configuration, std::vector<double> values);
  bool any() const { return false; }
  std::string description() const { return "no plane distortion"; }
  std::vector<std::string> base_models() const;  // every model
  std::string invalid() const { return ""; }
  Eigen::Vector2d offset(const Eigen::Vector2d&, Eigen::Matrix2d* jacobian = nullptr) const {
    if (jacobian) jacobian->setZero();
    return Eigen::Vector2d::Zero();
  }
  std::optional<double> evaluation_end(const PlaneRadius&, double theta_max) const { return theta_max; }
  std::string evaluation_problem(const PlaneRadius&, double) const { return ""; }
  bool operator==(const NoPlaneDistortion&) const = default;
};

// OpenCV's tangential and thin-prism terms (tangential.hpp) as a part.
struct TangentialDistortion {
  static constexpr std::string_view kName = "tangential";
  TangentialTerms terms;

  std::string configuration() const { return ""; }
  std::vector<double> values() const;
  std::vector<std::string> parameter_names() const;
  static TangentialDistortion from_numbers(std::string_view configuration, std::vector<double> values);
  bool any() const { return terms.any(); }
  std::string description() const { return "tangential terms"; }
  std::vector<std::string> base_models() const;  // the models with kTakesTangentialTerms
  std::string invalid() const;
  Eigen::Vector2d offset(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian = nullptr) const {
    return terms.offset(m, jacobian);
  }
  std::optional<double> evaluation_end(const PlaneRadius&, double theta_max) const { return theta_max; }
  std::string evaluation_problem(const PlaneRadius&, double) const { return ""; }
  bool operator==(const TangentialDistortion&) const = default;
};

// One of mrcal's lens models (mrcal_lens.hpp), evaluated by libmrcal, as a part.
struct MrcalLensDistortion {
  static constexpr std::string_view kName = "mrcal_lens";
  std::shared_ptr<const MrcalLens> lens;  // null: refused by Camera (invalid())

  std::string configuration() const { return lens ? lens->lensmodel() : ""; }
  std::vector<double> values() const { return lens ? lens->values() : std::vector<double>{}; }
  std::vector<std::string> parameter_names() const;
  static MrcalLensDistortion from_numbers(std::string_view configuration, std::vector<double> values);
  bool any() const { return true; }
  std::string description() const { return lens ? "mrcal's " + lens->lensmodel().substr(0, 80) : "no mrcal lens"; }
  std::vector<std::string> base_models() const;
  // MrcalLens checks its numbers when it is made: only its absence is left.
  std::string invalid() const { return lens ? "" : "lens: none given"; }
  Eigen::Vector2d offset(const Eigen::Vector2d& m, Eigen::Matrix2d* jacobian = nullptr) const {
    return lens->offset(m, jacobian);
  }
  // libmrcal's iteration (CAHVORE's) fails at and past a fold, and says so on
  // standard error: the rings on which it evaluates without a word.
  std::optional<double> evaluation_end(const PlaneRadius& radius, double theta_max) const;
  std::string evaluation_problem(const PlaneRadius& radius, double theta_max) const;
  bool operator==(const MrcalLensDistortion& other) const {
    return lens && other.lens ? *lens == *other.lens : lens == other.lens;
  }
};

template <class... Parts>
struct PlaneDistortionList {
  using Variant = std::variant<Parts...>;
  static constexpr size_t kSize = sizeof...(Parts);

  // f.template operator()<Part>() for every part, in registry order.
  template <class F>
  static void for_each(F&& f) {
    (f.template operator()<Parts>(), ...);
  }
};

using PlaneDistortionRegistry = PlaneDistortionList<NoPlaneDistortion,     //
                                                    TangentialDistortion,  //
                                                    MrcalLensDistortion>;

using PlaneDistortion = PlaneDistortionRegistry::Variant;

// Part names in registry order.
const std::vector<std::string_view>& plane_distortion_names();
std::string_view distortion_name(const PlaneDistortion& distortion);
bool displaces(const PlaneDistortion& distortion);  // the part's any()

// The one serialisation of a part: its name, configuration and numbers. A part that
// displaces nothing (tangential terms all zero) serialises as "none", so equal
// cameras give equal numbers.
struct PlaneDistortionNumbers {
  std::string name, configuration;
  std::vector<double> values;
  bool operator==(const PlaneDistortionNumbers&) const = default;
};
PlaneDistortionNumbers numbers_of(const PlaneDistortion& distortion);
// The part back from its numbers; throws Error for an unknown name ("distortion: unknown
// plane distortion 'x' (none, tangential, mrcal_lens)") or numbers the part refuses.
PlaneDistortion make_plane_distortion(std::string_view name, std::string_view configuration,
                                      std::vector<double> values);
// Whether two parts displace the plane alike (numbers_of equal).
bool same_distortion(const PlaneDistortion& a, const PlaneDistortion& b);

}  // namespace fishcam
