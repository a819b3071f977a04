#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <unordered_set>

#include "../python_literal.hpp"
#include "format.hpp"

namespace fishcam::detail {
namespace {

std::string_view trimmed(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

}  // namespace

// ------------------------------------------------------------ Content
const nlohmann::json* Content::json() const {
  if (!json_tried_) {
    json_tried_ = true;
    try {
      // Duplicate keys: nlohmann keeps the last, other parsers the first; which is
      // meant cannot be known, so the file is refused naming the key.
      std::vector<std::unordered_set<std::string>> keys;  // per open object
      std::string duplicate;
      // The node budget is spent while parsing, as for YAML.
      std::size_t nodes = 0;
      const auto check_keys = [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
        using Event = nlohmann::json::parse_event_t;
        if (event != Event::key && event != Event::object_end && event != Event::array_end &&
            ++nodes > kMaxDocumentNodes) {
          throw Error(source_ + ": not a readable JSON file (more than " + std::to_string(kMaxDocumentNodes) +
                      " values)");
        }
        if (event == Event::object_start) keys.emplace_back();
        if (event == Event::object_end && !keys.empty()) keys.pop_back();
        if (event == Event::key && !keys.empty()) {
          const std::string& key = parsed.get_ref<const std::string&>();
          if (!keys.back().insert(key).second && duplicate.empty()) duplicate = key;
        }
        return true;
      };
      nlohmann::json parsed = nlohmann::json::parse(text_, check_keys);
      if (!duplicate.empty()) {
        throw Error(source_ + ": the key " + quoted_for_message(duplicate) + " appears twice in one object");
      }
      json_ = std::move(parsed);
    } catch (const nlohmann::json::exception& e) {  // parse errors, and number overflow ('1e400')
      json_error_ = e.what();
      if (const auto pos = json_error_.find("] "); pos != std::string::npos) json_error_ = json_error_.substr(pos + 2);
    }
  }
  return json_ ? &*json_ : nullptr;
}

const nlohmann::json& Content::json_or_throw() const {
  if (const auto* j = json()) return *j;
  throw Error(source_ + ": not valid JSON (" + quoted_for_message(json_error_, 120) + ")");
}

namespace {

// A parsed JSON value (or Python literal) as a document; scalars keep their type
// in the tag.
DocNode document_of(const nlohmann::json& j) {
  DocNode node;
  if (j.is_object()) {
    node.kind = DocNode::Kind::map;
    for (const auto& [key, value] : j.items()) {
      node.keys.push_back(key);
      node.items.push_back(document_of(value));
    }
  } else if (j.is_array()) {
    node.kind = DocNode::Kind::sequence;
    for (const auto& value : j) node.items.push_back(document_of(value));
  } else if (!j.is_null()) {
    node.kind = DocNode::Kind::scalar;
    node.tag = j.is_string() ? "str" : j.is_boolean() ? "bool" : "float";
    // Numbers round-trip exactly through dump(); a Python literal's nan or inf stays one.
    const bool non_finite = j.is_number_float() && !std::isfinite(j.get<double>());
    node.scalar = j.is_string() ? j.get<std::string>() : non_finite ? (j.get<double>() > 0 ? "inf" : "nan") : j.dump();
    if (non_finite && j.get<double>() < 0) node.scalar = "-inf";
  }
  return node;
}

// What a JSON-typed scalar is, in messages ("expected a number, got string").
std::string json_type(const DocNode& n) {
  if (n.kind == DocNode::Kind::map) return "object";
  if (n.kind == DocNode::Kind::sequence) return "array";
  if (n.kind == DocNode::Kind::null) return "null";
  return n.tag == "str" ? "string" : n.tag == "bool" ? "boolean" : "number";
}

}  // namespace

const DocNode& Content::json_document() const {
  if (!json_document_) json_document_ = document_of(json_or_throw());
  return *json_document_;
}

const DocNode* Content::python_literal_document() const {
  if (!literal_document_) {
    if (const auto* literal = python_literal()) literal_document_ = document_of(*literal);
  }
  return literal_document_ ? &*literal_document_ : nullptr;
}

const DocNode* Content::yaml() const {
  if (!yaml_tried_) {
    yaml_tried_ = true;
    try {
      std::string_view start = text_;
      while (!start.empty() && std::isspace(static_cast<unsigned char>(start.front()))) start.remove_prefix(1);
      yaml_ = start.starts_with("<") ? parse_xml(text_, source_) : parse_yaml(text_, source_);
    } catch (const Error& e) {
      yaml_error_ = e.what();
    }
  }
  return yaml_ ? &*yaml_ : nullptr;
}

const DocNode& Content::yaml_or_throw() const {
  if (const auto* y = yaml()) return *y;
  throw Error(yaml_error_);
}

const nlohmann::json* Content::python_literal() const {
  if (!literal_tried_) {
    literal_tried_ = true;
    try {
      literal_ = parse_python_literal(text_);
    } catch (const Error& e) {
      literal_error_ = e.what();
    }
  }
  return literal_ ? &*literal_ : nullptr;
}

// ------------------------------------------------------------ DocFields
void DocFields::fail(std::string_view key, std::string_view problem) const {
  throw Error(source_ + ": " + text_for_message(prefix_ + std::string(key)) + ": " + std::string(problem));
}

const DocNode& DocFields::get(std::string_view key) const {
  const DocNode* n = node_.find(key);
  if (!n) fail(key, "missing");
  return *n;
}

double DocFields::parse_number(const std::string& text, const std::function<void(std::string_view)>& fail) {
  const std::string t(trimmed(text));
  // YAML's own spellings of the non-finite numbers (OpenCV writes them).
  for (const char* special : {".nan", ".NaN", ".NAN", ".inf", ".Inf", ".INF", "-.inf", "-.Inf", "-.INF", "+.inf"}) {
    if (t == special) fail("must be finite");
  }
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (t.empty() || end == t.c_str() || !trimmed(end).empty())
    fail("expected a number, got " + quoted_for_message(text));
  if (!std::isfinite(v)) fail("must be finite");
  return v;
}

double DocFields::number(std::string_view key) const {
  const DocNode& n = get(key);
  if (n.kind != DocNode::Kind::scalar) fail(key, "expected a number");
  if (n.tag == "str" || n.tag == "bool") fail(key, "expected a number, got " + json_type(n));
  return parse_number(n.scalar, [&](std::string_view problem) { fail(key, problem); });
}

int DocFields::positive_integer(std::string_view key) const {
  const DocNode& n = get(key);
  if (n.kind != DocNode::Kind::scalar) fail(key, "expected an integer");
  if (n.tag == "str" || n.tag == "bool") fail(key, "expected an integer, got " + json_type(n));
  const double v = parse_number(n.scalar, [&](std::string_view problem) {
    fail(key,
         problem.starts_with("expected a number") ? "expected an integer" + std::string(problem.substr(17)) : problem);
  });
  if (!(v >= 1 && v <= (1 << 16)) || v != std::floor(v)) fail(key, "expected a positive integer <= 65536");
  return static_cast<int>(v);
}

std::string DocFields::string(std::string_view key) const {
  const DocNode& n = get(key);
  if (n.kind != DocNode::Kind::scalar) fail(key, "expected text");
  if (n.tag == "float" || n.tag == "bool") fail(key, "expected a string, got " + json_type(n));
  if (n.tag == "str") return n.scalar;  // JSON: the string as it is
  std::string s(trimmed(n.scalar));
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);  // XML keeps quotes
  return s;
}

std::vector<double> DocFields::numbers(std::string_view key, size_t min_size, size_t max_size) const {
  return numbers_of(get(key), key, min_size, max_size);
}

std::vector<double> DocFields::numbers(std::string_view key, size_t index, size_t min_size, size_t max_size) const {
  const DocNode& n = get(key);
  const std::string name = std::string(key) + "[" + std::to_string(index) + "]";
  if (n.kind != DocNode::Kind::sequence || index >= n.items.size()) fail(name, "missing");
  return numbers_of(n.items[index], name, min_size, max_size);
}

std::vector<double> DocFields::numbers_of(const DocNode& n, std::string_view key, size_t min_size,
                                          size_t max_size) const {
  std::vector<std::string> texts;
  const DocNode* data = &n;
  std::string item_prefix(key);
  if (n.kind == DocNode::Kind::map && n.find("data"))
    data = n.find("data"), item_prefix += ".data";  // an opencv-matrix
  if (data->kind == DocNode::Kind::sequence) {
    for (const auto& item : data->items) {
      if (item.kind != DocNode::Kind::scalar) fail(key, "expected a list of numbers");
      if (item.tag == "str" || item.tag == "bool") fail(key, "expected a list of numbers, got a " + json_type(item));
      texts.push_back(item.scalar);
      if (texts.size() > max_size) break;
    }
  } else if (data->kind == DocNode::Kind::scalar && data->tag.empty()) {  // XML: whitespace-separated
    std::istringstream words(data->scalar);
    for (std::string word; words >> word && texts.size() <= max_size;) texts.push_back(word);
  } else {
    fail(key, "expected a list of numbers");
  }
  if (texts.size() < min_size || texts.size() > max_size) {
    // Past max_size the count stopped early: "more".
    const std::string got = texts.size() > max_size ? "more" : std::to_string(texts.size());
    fail(key, (min_size == max_size
                   ? "expected " + std::to_string(min_size) + " numbers"
                   : "expected " + std::to_string(min_size) + " to " + std::to_string(max_size) + " numbers") +
                  ", got " + got);
  }
  std::vector<double> out;
  for (size_t i = 0; i < texts.size(); ++i) {
    out.push_back(
        parse_number(texts[i], [&](std::string_view p) { fail(item_prefix + "[" + std::to_string(i) + "]", p); }));
  }
  return out;
}

std::vector<double> DocFields::matrix(std::string_view key, int count) const {
  const DocNode& n = get(key);
  if (n.kind != DocNode::Kind::map || !n.find("rows") || !n.find("cols") || !n.find("data")) {
    fail(key, "expected an opencv-matrix (rows, cols, dt, data)");
  }
  const DocFields m(n, source_, prefix_ + std::string(key) + ".");
  const double rows = m.number("rows"), cols = m.number("cols");
  if (rows < 1 || cols < 1 || rows * cols != count)
    fail(key, "expected " + std::to_string(count) + " elements (rows x cols)");
  return m.numbers("data", size_t(count), size_t(count));
}

DocFields DocFields::object(std::string_view key) const {
  const DocNode& n = get(key);
  if (n.kind != DocNode::Kind::map) fail(key, "expected a map");
  return DocFields(n, source_, prefix_ + std::string(key) + ".");
}

size_t DocFields::size(std::string_view key) const {
  const DocNode& n = get(key);
  if (n.kind != DocNode::Kind::sequence) fail(key, "expected a list");
  return n.items.size();
}

DocFields DocFields::item(std::string_view key, size_t index) const {
  const DocNode& n = get(key);
  const std::string name = std::string(key) + "[" + std::to_string(index) + "]";
  if (n.kind != DocNode::Kind::sequence || index >= n.items.size()) fail(name, "missing");
  if (n.items[index].kind != DocNode::Kind::map) fail(name, "expected a map");
  return DocFields(n.items[index], source_, prefix_ + name + ".");
}

// ------------------------------------------------------------ models, poses, text
bool FormatSpec::holds_model(std::string_view model) const {
  return models.empty() || std::find(models.begin(), models.end(), model) != models.end();
}

namespace {
// The parameters of the camera's part that the declaration does not hold and that
// are not zero; nullopt when the format does not hold the part at all.
std::optional<std::vector<std::string>> unheld_parameters(const std::vector<HeldDistortion>& held,
                                                          const PlaneDistortion& distortion) {
  const std::string_view part = distortion_name(distortion);
  const auto it = std::find_if(held.begin(), held.end(), [&](const HeldDistortion& h) { return h.part == part; });
  if (it == held.end()) return std::nullopt;
  const auto [names, values] =
      std::visit([](const auto& d) { return std::pair(d.parameter_names(), d.values()); }, distortion);
  std::vector<std::string> unheld;
  if (it->parameters.empty()) return unheld;
  for (size_t i = 0; i < names.size(); ++i) {
    const bool listed = std::find(it->parameters.begin(), it->parameters.end(), names[i]) != it->parameters.end();
    if (!listed && values[i] != 0) unheld.push_back(names[i]);
  }
  return unheld;
}

bool holds_distortion(const FormatSpec& spec, const PlaneDistortion& distortion) {
  if (!displaces(distortion)) return true;
  const auto unheld = unheld_parameters(spec.distortions, distortion);
  return unheld && unheld->empty();
}
}  // namespace

std::string FormatSpec::cannot_hold_distortion(const PlaneDistortion& distortion) const {
  if (holds_distortion(*this, distortion)) return "";
  std::string others;
  for (const FormatSpec* spec : format_table()) {
    if (holds_distortion(*spec, distortion))
      others += std::string(others.empty() ? "" : ", ") + std::string(spec->name);
  }
  const std::string part(distortion_name(distortion));
  const std::string what = std::visit([](const auto& d) { return d.description(); }, distortion);
  const auto unheld = unheld_parameters(distortions, distortion);
  std::string why = part + ": the " + std::string(name) + " format cannot hold ";
  if (unheld) {
    std::string list;
    for (const std::string& n : *unheld) list += std::string(list.empty() ? "" : ", ") + n;
    why += list + " of the " + what;
  } else {
    why += what;
  }
  return why + " (" + (others.empty() ? "no format" : others) + " can)";
}

void cannot_hold(const CameraParameters& camera, CameraFormat format) {
  const FormatSpec& spec = format_spec(format);
  const std::vector<std::string> names(spec.models.begin(), spec.models.end());
  throw Error("model: the " + std::string(spec.name) + " format holds " + choices_for_message(names, "and") +
              " models only, not " + std::string(model_name(camera.model)));
}

CameraParameters with_unit_ax(CameraParameters p) {
  const double ax = p.grid.pixel_scale.x();
  p.model = std::visit([&](const auto& m) { return RadialModel(m.scaled(ax)); }, p.model);
  p.grid.pixel_scale = {1.0, p.grid.pixel_scale.y() / ax};
  return p;
}

void set_focal(CameraParameters* p, double fx, double fy, const std::function<void(std::string_view)>& fail) {
  if (!(fx > 0) || !(fy > 0)) fail("fx and fy must be > 0");
  p->grid.pixel_scale = {1.0, fy / fx};
}

KannalaBrandtLike kannala_brandt_of(const CameraParameters& p) {
  KannalaBrandtLike out;
  if (const auto* m = std::get_if<KannalaBrandt<double>>(&p.model)) {
    const auto params = m->params();
    out = {true, params[0], {params[1], params[2], params[3], params[4]}};
  } else if (const auto* m = std::get_if<Equidistant<double>>(&p.model)) {
    out = {true, m->f(), {0, 0, 0, 0}};
  }
  return out;
}

KannalaBrandtOrPinhole kannala_brandt_or_pinhole(const CameraParameters& p, CameraFormat format) {
  KannalaBrandtOrPinhole out;
  if (const auto* m = std::get_if<Pinhole<double>>(&p.model)) {
    out.pinhole = true, out.fx = m->f();
  } else {
    const KannalaBrandtLike kb = kannala_brandt_of(p);
    if (!kb.ok) cannot_hold(p, format);
    out.fx = kb.f, out.k = kb.k;
  }
  out.fy = out.fx * p.grid.pixel_scale.y();
  out.cx = p.grid.principal_point.x(), out.cy = p.grid.principal_point.y();
  return out;
}

std::optional<RadialTangential> radial_tangential_of(const CameraParameters& p) {
  RadialTangential out;
  const TangentialTerms t = p.tangential_terms();
  if (const auto* m = std::get_if<Pinhole<double>>(&p.model)) {
    out.f = m->f();
    out.d = {0, 0, t.p1, t.p2, 0};
    out.rational = false;
  } else if (const auto* m = std::get_if<OpenCV<double>>(&p.model)) {
    const std::vector<double> q = m->params();
    out.f = q[0];
    out.d = {q[1], q[2], t.p1, t.p2, q[3], q[4], q[5], q[6]};
    out.rational = true;
  } else {
    return std::nullopt;
  }
  if (t.any_thin_prism()) {
    out.d.resize(8, 0.0);
    out.d.insert(out.d.end(), t.s.begin(), t.s.end());
  }
  return out;
}

void set_radial_tangential(CameraParameters* p, const std::vector<double>& d, double f,
                           const std::function<void(std::string_view)>& fail) {
  const size_t n = d.size();
  if (n != 0 && n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
    fail(
        "expected 4, 5, 8, 12 or 14 radial-tangential coefficients (OpenCV's order k1, k2, p1, p2, k3, k4, k5, k6, "
        "s1, s2, s3, s4, tau_x, tau_y), got " +
        std::to_string(n));
  }
  const auto coefficient = [&](size_t i) { return i < n ? d[i] : 0.0; };
  if (coefficient(12) != 0 || coefficient(13) != 0) fail("a tilted sensor (tau_x, tau_y != 0) is not supported");
  const std::array<double, 6> k{coefficient(0), coefficient(1), coefficient(4),
                                coefficient(5), coefficient(6), coefficient(7)};
  if (std::all_of(k.begin(), k.end(), [](double x) { return x == 0; })) {
    p->model = Pinhole<double>(f);
  } else {
    p->model = OpenCV<double>(f, k[0], k[1], k[2], k[3], k[4], k[5]);
  }
  p->distortion = TangentialDistortion{
      {coefficient(2), coefficient(3), {coefficient(8), coefficient(9), coefficient(10), coefficient(11)}}};
}

Pose pose_from_rt_cam_ref(const std::vector<double>& rt) {
  const Eigen::Vector3d r(rt[0], rt[1], rt[2]), t(rt[3], rt[4], rt[5]);
  const double angle = r.norm();
  const Eigen::Matrix3d r_cam_ref =
      angle > 0 ? Eigen::AngleAxisd(angle, r / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  Pose pose;
  pose.rotation = Eigen::Quaterniond(r_cam_ref.transpose());
  pose.translation = -(r_cam_ref.transpose() * t);
  return pose;
}

std::array<double, 6> rt_cam_ref_from_pose(const Pose& pose) {
  const Eigen::Quaterniond q_cam_ref = pose.rotation.conjugate();
  const Eigen::AngleAxisd aa(q_cam_ref);
  const Eigen::Vector3d r = aa.axis() * aa.angle();
  const Eigen::Vector3d t = -(q_cam_ref * pose.translation);
  return {r.x(), r.y(), r.z(), t.x(), t.y(), t.z()};
}

std::optional<Pose> pose_from_matrix(const std::vector<double>& m, std::string* problem) {
  if (m.size() != 16) return *problem = "expected a 4x4 matrix", std::nullopt;
  if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1)
    return *problem = "the last row must be 0 0 0 1", std::nullopt;
  Eigen::Matrix3d r;
  r << m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10];
  if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-6) || !(r.determinant() > 0)) {
    return *problem = "the rotation is not orthonormal (to 1e-6)", std::nullopt;
  }
  Pose pose;
  pose.rotation = Eigen::Quaterniond(r).normalized();
  pose.translation = {m[3], m[7], m[11]};
  return pose;
}

std::array<double, 16> matrix_from_pose(const Pose& pose) {
  const Eigen::Matrix3d r = pose.rotation.toRotationMatrix();
  const Eigen::Vector3d& t = pose.translation;
  return {r(0, 0), r(0, 1), r(0, 2), t.x(), r(1, 0), r(1, 1), r(1, 2), t.y(),
          r(2, 0), r(2, 1), r(2, 2), t.z(), 0,       0,       0,       1};
}

Pose pose_from_json(const DocFields& f, const char* quaternion_key) {
  const std::vector<double> q = f.numbers(quaternion_key, 4, 4);
  const std::vector<double> t = f.numbers("translation", 3, 3);
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (std::abs(norm - 1) > 1e-6) f.fail(quaternion_key, "must have unit norm, got " + std::to_string(norm));
  return Pose{Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized(), Eigen::Vector3d(t[0], t[1], t[2])};
}

nlohmann::json pose_to_json(const Pose& pose, const char* quaternion_key) {
  const auto& q = pose.rotation;
  const auto& t = pose.translation;
  return {{quaternion_key, {q.x(), q.y(), q.z(), q.w()}}, {"translation", {t.x(), t.y(), t.z()}}};
}

std::string yaml_number(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", x);
  std::string s = buffer;
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";  // stays a float in every reader
  return s;
}

std::string yaml_list(const std::vector<double>& values) {
  std::string s = "[";
  for (size_t i = 0; i < values.size(); ++i) s += (i ? ", " : "") + yaml_number(values[i]);
  return s + "]";
}

}  // namespace fishcam::detail
