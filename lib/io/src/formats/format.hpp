// The table of camera file formats and what their readers and writers share.
//
// How to add a format: see fishcam/io/camera_format_list.hpp (its .cpp, one line
// there, its section in docs/formats.md; the enum, this table and the fuzz
// harnesses follow from the list).
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "../document.hpp"
#include "fishcam/io/camera_io.hpp"

namespace fishcam::detail {

// A file's text with its parsed views, each parsed at most once (detection asks
// every format; readers reuse the parse).
class Content {
 public:
  Content(std::string_view text, std::string source, const CameraReadOptions* options = nullptr)
      : text_(text), source_(std::move(source)), options_(options) {}
  // What the caller said about the file (nullptr: nothing).
  const CameraReadOptions* options() const { return options_; }
  std::string_view text() const { return text_; }
  const std::string& source() const { return source_; }
  // nullptr when the text is not that (the parse error is kept for readers).
  const nlohmann::json* json() const;
  const DocNode* yaml() const;  // YAML, or XML for text starting with '<'
  const nlohmann::json* python_literal() const;
  const std::string& python_literal_error() const { return literal_error_; }
  // The parsed views or a one-line error naming the file.
  const nlohmann::json& json_or_throw() const;
  const DocNode& yaml_or_throw() const;
  // The JSON or the Python literal as a document, the one tree readers walk with
  // DocFields whatever the syntax (converted once; scalars keep their JSON type in
  // DocNode::tag: "str", "float", "bool").
  const DocNode& json_document() const;
  const DocNode* python_literal_document() const;

 private:
  std::string_view text_;
  std::string source_;
  const CameraReadOptions* options_;
  mutable std::optional<nlohmann::json> json_, literal_;
  mutable std::optional<DocNode> yaml_, json_document_, literal_document_;
  mutable bool json_tried_ = false, yaml_tried_ = false, literal_tried_ = false;
  mutable std::string json_error_, yaml_error_, literal_error_;
};

struct NamedCamera {
  std::string name;                // as the file names it ("cam0"), or its index
  CameraParameters camera;         // width = height = 0 when the file has no image size
  std::vector<std::string> notes;  // what the reader did not take (said on stderr by the CLI)
};

// A plane distortion a format holds (fishcam/core/plane_distortion.hpp), named as the
// registry names it, and which of its parameters (empty: every one). Every format
// holds "none"; format_camera refuses a camera whose part, or a non-zero parameter
// of it, its format does not list.
struct HeldDistortion {
  std::string_view part;
  std::vector<std::string_view> parameters;
};

// What a format keeps of a camera beyond its model and plane distortion.
struct HeldExtras {
  bool skew = false;  // a skewed pixel grid (CameraParameters::skew)
  // A user limit on the valid domain (fishcam JSON only).
  bool theta_limit = false;
  // Stores a_x as it is (fishcam JSON); every other writer is given the camera
  // rescaled to a_x = 1 (f = fx, a_y = fy / fx) by format_camera.
  bool pixel_scale = false;
  // A calibration record (observed angles, covariance); format_camera drops the
  // record for the others (callers say so: camera_format_holds_calibration_record).
  bool calibration_record = false;
};

// One format, declared with designated initialisers (formats/NAME.cpp).
struct FormatSpec {
  CameraFormat id;
  std::string_view name;
  std::string_view description;              // "Kalibr camchain YAML"
  std::vector<std::string_view> extensions;  // for choosing a writer from a file name
  // The registry models its writer takes (empty: every one). format_camera checks
  // a camera against it before the writer runs; the tests and docs/formats.md's
  // table follow from it.
  std::vector<std::string_view> models;
  // The plane distortions it holds besides "none", as models are declared.
  std::vector<HeldDistortion> distortions = {};
  // How surely the content is this format: 0 = not it; higher = surer (by parsing
  // and looking for the format's own keys, never by substring order).
  int (*score)(const Content&);
  std::vector<NamedCamera> (*read)(const Content&);
  std::string (*write)(const CameraParameters&);  // throws Error when it cannot hold the camera
  // Several cameras with their poses relative to the first (camera -> camera 0), in
  // one file; nullptr for formats that hold one camera.
  std::string (*write_rig)(const std::vector<CameraParameters>&) = nullptr;
  HeldExtras holds = {};

  bool holds_model(std::string_view model) const;
  // "" when the format holds the camera's plane distortion, else why not.
  std::string cannot_hold_distortion(const PlaneDistortion& distortion) const;
};

const std::vector<const FormatSpec*>& format_table();
const FormatSpec& format_spec(CameraFormat format);

// ------------------------------------------------------------ shared helpers

// Typed, named access to a document's map (YAML, XML, JSON, a Python literal):
// every failure says file, field and problem. Scalars are text, numbers parsed
// here; a JSON string is never taken for a number, nor a JSON number for a string.
class DocFields {
 public:
  DocFields(const DocNode& node, std::string source, std::string prefix = "")
      : node_(node), source_(std::move(source)), prefix_(std::move(prefix)) {}
  [[noreturn]] void fail(std::string_view key, std::string_view problem) const;
  bool has(std::string_view key) const { return node_.find(key) != nullptr; }
  const DocNode& get(std::string_view key) const;
  double number(std::string_view key) const;
  int positive_integer(std::string_view key) const;
  std::string string(std::string_view key) const;
  // A list of numbers: a YAML sequence, or an opencv-matrix's data.
  std::vector<double> numbers(std::string_view key, size_t min_size, size_t max_size) const;
  // The list of numbers key[index] (a list of lists).
  std::vector<double> numbers(std::string_view key, size_t index, size_t min_size, size_t max_size) const;
  // An opencv-matrix (rows, cols, data) with `count` elements.
  std::vector<double> matrix(std::string_view key, int count) const;
  DocFields object(std::string_view key) const;
  DocFields item(std::string_view key, size_t index) const;  // key[index], a map
  size_t size(std::string_view key) const;                   // length of the list `key`
  const DocNode& node() const { return node_; }
  const std::string& source() const { return source_; }

  static double parse_number(const std::string& text, const std::function<void(std::string_view)>& fail);

 private:
  std::vector<double> numbers_of(const DocNode& n, std::string_view key, size_t min_size, size_t max_size) const;
  const DocNode& node_;
  std::string source_, prefix_;
};

// A format's error about the model it was given: "model: the kalibr format holds
// kannala-brandt, ... models only, not polynomial" (its FormatSpec::models).
[[noreturn]] void cannot_hold(const CameraParameters& camera, CameraFormat format);
// The model rescaled so that a_x = 1 (formats with fx, fy store f = fx, a_y = fy / fx).
CameraParameters with_unit_ax(CameraParameters p);
// K = [fx 0 cx; 0 fy cy] from fx, fy: f = fx, a_y = fy / fx. Throws unless fx, fy > 0.
void set_focal(CameraParameters* p, double fx, double fy, const std::function<void(std::string_view)>& fail);

// Kannala-Brandt's f and k1..k4 of a camera whose model is kannala-brandt or
// equidistant (k = 0); ok = false for any other model.
struct KannalaBrandtLike {
  bool ok = false;
  double f = 0;
  std::array<double, 4> k{};
};
KannalaBrandtLike kannala_brandt_of(const CameraParameters& p);
// For the formats that hold kannala-brandt (and equidistant) and pinhole models, of
// a camera with a_x = 1: K's fx, fy, cx, cy and k1..k4 (0 for a pinhole), or Error
// naming the model the format cannot hold.
struct KannalaBrandtOrPinhole {
  bool pinhole = false;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 4> k{};
};
KannalaBrandtOrPinhole kannala_brandt_or_pinhole(const CameraParameters& p, CameraFormat format);
// OpenCV's radial-tangential coefficients in its order (k1, k2, p1, p2[, k3[, k4,
// k5, k6[, s1, s2, s3, s4[, tau_x, tau_y]]]]: 0, 4, 5, 8, 12 or 14 of them) with
// focal length f, as p's model (`pinhole` when k1..k6 are zero, else `opencv`) and
// tangential terms (p1, p2, s1..s4). A tilted sensor is refused.
void set_radial_tangential(CameraParameters* p, const std::vector<double>& d, double f,
                           const std::function<void(std::string_view)>& fail);
// The writers' side: a pinhole or opencv camera (with its tangential terms) as f
// and OpenCV's coefficients k1, k2, p1, p2, k3[, k4, k5, k6[, s1, s2, s3, s4]]: 5 for
// a pinhole, 8 for opencv, 12 with thin-prism terms; nullopt for any other model.
struct RadialTangential {
  double f = 0;
  std::vector<double> d;
  bool rational = false;  // k4..k6 are there (opencv): OpenCV's rational_polynomial
};
std::optional<RadialTangential> radial_tangential_of(const CameraParameters& p);

// Poses: rt_cam_ref (mrcal, OpenCV YAML) and 4x4 row-major transforms.
Pose pose_from_rt_cam_ref(const std::vector<double>& rt);
std::array<double, 6> rt_cam_ref_from_pose(const Pose& pose);
// A 4x4 row-major rigid transform (last row 0 0 0 1, rotation orthonormal to 1e-6).
std::optional<Pose> pose_from_matrix(const std::vector<double>& m16, std::string* problem);
std::array<double, 16> matrix_from_pose(const Pose& pose);
// A pose as JSON: quaternion (x, y, z, w: scalar last, unit norm to 1e-6) under
// quaternion_key, and "translation".
Pose pose_from_json(const DocFields& f, const char* quaternion_key);
nlohmann::json pose_to_json(const Pose& pose, const char* quaternion_key);

// YAML text helpers for writers (numbers with 17 significant digits).
std::string yaml_number(double x);
std::string yaml_list(const std::vector<double>& values);

}  // namespace fishcam::detail
