#include "fishcam/io/camera_io.hpp"

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <numbers>
#include <sstream>

#include "fishcam/core/error.hpp"
#include "fishcam/io/atomic_file.hpp"
#include "fishcam/io/file_input.hpp"
#include "formats/format.hpp"

namespace fishcam {
namespace {

using detail::format_spec;
using detail::format_table;
using nlohmann::json;

// Editors on Windows start text files with a UTF-8 byte order mark; no format means
// anything by it.
std::string_view without_byte_order_mark(std::string_view content) {
  return content.starts_with("\xEF\xBB\xBF") ? content.substr(3) : content;
}

// A camera file's bytes, bounded before anything is read (fishcam/io/file_input.hpp).
std::string read_camera_file(const std::filesystem::path& path) {
  return read_bounded_file(path, detail::kMaxDocumentBytes, "a camera file");
}

// Magnitudes no camera has: a file holding them is corrupt (or a fuzzer's), and its
// numbers would overflow every computation downstream (round trips missed by 1e291 px).
constexpr double kMaxPixels = 1e6;        // principal point, focal length (px)
constexpr double kPixelScaleRange = 1e6;  // a_x, a_y within [1e-6, 1e6]

std::string magnitude_problem(const Camera& camera) {
  const CameraParameters& p = camera.parameters();
  const auto pixels = [](double v) { return std::abs(v) <= kMaxPixels; };
  if (!pixels(p.grid.principal_point.x()) || !pixels(p.grid.principal_point.y())) {
    return "principal_point: expected within +-" + number_for_message(kMaxPixels) + " px, got (" +
           number_for_message(p.grid.principal_point.x()) + ", " + number_for_message(p.grid.principal_point.y()) + ")";
  }
  for (double a : {p.grid.pixel_scale.x(), p.grid.pixel_scale.y()}) {  // negative: a mirrored grid
    if (!(std::abs(a) >= 1 / kPixelScaleRange && std::abs(a) <= kPixelScaleRange)) {
      return "pixel_scale: expected within [" + number_for_message(1 / kPixelScaleRange) + ", " +
             number_for_message(kPixelScaleRange) + "] (negated: a mirrored grid), got " + number_for_message(a);
    }
  }
  const double focal = camera.drho(0) * p.grid.pixel_scale.cwiseAbs().maxCoeff();
  if (!(focal <= kMaxPixels)) {
    return "the focal length (rho'(0) a) must be at most " + number_for_message(kMaxPixels) + " px, got " +
           number_for_message(focal);
  }
  // An image of which no pixel has a ray (a principal point far off the image, a
  // domain that ends before the image begins) describes no camera.
  const bool centred = p.grid.principal_point.x() >= -0.5 && p.grid.principal_point.y() >= -0.5 &&
                       p.grid.principal_point.x() <= p.width - 0.5 && p.grid.principal_point.y() <= p.height - 0.5;
  if (!centred) {
    constexpr int kSamples = 32;
    Eigen::Vector3d ray;
    bool sees = false;
    for (int j = 0; j <= kSamples && !sees; ++j) {
      for (int i = 0; i <= kSamples && !sees; ++i) {
        sees = camera.unproject({-0.5 + p.width * double(i) / kSamples, -0.5 + p.height * double(j) / kSamples}, &ray);
      }
    }
    if (!sees) return "no pixel of the image has a ray (the principal point or the valid domain lies off the image)";
  }
  return "";
}

// Builds the camera so its own validation errors also name the file.
CameraParameters validated(CameraParameters p, std::string_view source) {
  try {
    const Camera check(p);
    if (const std::string problem = magnitude_problem(check); !problem.empty()) throw Error(problem);
  } catch (const Error& e) {
    throw Error(std::string(source) + ": " + e.what());
  }
  return p;
}

// "A, B, C" of one field of every format.
std::string joined(std::string_view detail::FormatSpec::*field) {
  std::string text;
  for (const auto* spec : format_table()) text += (text.empty() ? "" : ", ") + std::string(spec->*field);
  return text;
}

}  // namespace

std::string_view to_string(CameraFormat format) { return format_spec(format).name; }

std::optional<CameraFormat> parse_camera_format(std::string_view name) {
  for (const auto* spec : format_table()) {
    if (name == spec->name) return spec->id;
  }
  return std::nullopt;
}

std::vector<CameraFormat> camera_formats() {
  std::vector<CameraFormat> formats;
  for (const auto* spec : format_table()) formats.push_back(spec->id);
  return formats;
}

std::string camera_format_names() { return joined(&detail::FormatSpec::name); }

std::optional<CameraFormat> camera_format_for_extension(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  // Extensions several formats share go to the first of: fishcam (.json), opencv (.yaml).
  for (CameraFormat preferred :
       {CameraFormat::mrcal, CameraFormat::fishcam, CameraFormat::opencv, CameraFormat::colmap}) {
    for (std::string_view e : format_spec(preferred).extensions) {
      if (ext == e) return preferred;
    }
  }
  return std::nullopt;
}

CameraFormat detect_camera_format(std::string_view content, std::string_view source_name) {
  content = without_byte_order_mark(content);
  const detail::Content c(content, std::string(source_name));
  std::string_view start = content;
  while (!start.empty() && std::isspace(static_cast<unsigned char>(start.front()))) start.remove_prefix(1);
  if (start.empty()) throw Error(std::string(source_name) + ": empty file");
  const detail::FormatSpec* best = nullptr;
  int best_score = 0;
  for (const auto* spec : format_table()) {
    const int score = spec->score(c);
    if (score > best_score) best = spec, best_score = score;
  }
  if (best) return best->id;
  // Nothing recognised it.
  // Where the text does not even parse, the reader of the
  // syntax it tries to be says why (the parse error, with its line).
  if (content.find("lensmodel") != std::string_view::npos && !c.python_literal()) return CameraFormat::mrcal;
  // A syntax error belongs to no format: said as it is, without "(read as ...)".
  if ((start.starts_with("{") || start.starts_with("[")) && (!c.json() || !c.json()->is_object())) {
    if (!c.json()) c.json_or_throw();
    return CameraFormat::woodscape;
  }
  const bool binary = content.find('\0') != std::string_view::npos;
  if (!binary && !c.yaml()) c.yaml_or_throw();
  if (!binary && (start.starts_with("<") || start.starts_with("%YAML"))) return CameraFormat::opencv;
  throw Error(std::string(source_name) +
              ": unrecognised camera file (expected one of: " + joined(&detail::FormatSpec::description) + ")");
}

namespace {

// Every camera of a file, parsed once.
std::vector<detail::NamedCamera> read_all(const detail::Content& c, CameraFormat format) {
  const auto& spec = format_spec(format);
  try {
    return spec.read(c);
  } catch (const Error& e) {
    const std::string what = e.what();
    // Say which format the file looked like (the field errors name the file already).
    if (what.find(" (read as ") != std::string::npos) throw;
    throw Error(what + " (read as " + std::string(spec.description) + ")");
  }
}

}  // namespace

CameraParameters parse_camera(std::string_view content, std::string_view source_name, const CameraReadOptions& options,
                              CameraFileInfo* info) {
  content = without_byte_order_mark(content);
  const std::string source(source_name);
  const detail::Content c(content, source, &options);
  const CameraFormat format = options.format ? *options.format : detect_camera_format(content, source_name);
  std::vector<detail::NamedCamera> cameras = read_all(c, format);
  size_t index = 0;
  if (options.camera) {
    const std::string& wanted = *options.camera;
    bool found = false;
    for (size_t i = 0; i < cameras.size() && !found; ++i) {
      if (cameras[i].name == wanted) index = i, found = true;
    }
    if (!found && !wanted.empty() && wanted.find_first_not_of("0123456789") == std::string::npos && wanted.size() < 6) {
      index = std::stoul(wanted), found = index < cameras.size();
    }
    if (!found) {
      std::string names;
      for (size_t i = 0; i < cameras.size(); ++i) {
        names += (i ? ", " : "") + std::to_string(i) + " = " + quoted_for_message(cameras[i].name);
      }
      throw Error(source + ": camera: no camera " + quoted_for_message(wanted) + " (the file has " + names + ")");
    }
  }
  detail::NamedCamera chosen = std::move(cameras[index]);
  CameraParameters& p = chosen.camera;
  if (p.width == 0 && p.height == 0) {
    if (!options.image_size) {
      throw Error(source + ": image_size: the " + std::string(format_spec(format).description) +
                  " file has no image size; give one");
    }
    p.width = options.image_size->first, p.height = options.image_size->second;
  } else if (options.image_size && (options.image_size->first != p.width || options.image_size->second != p.height)) {
    throw Error(source + ": image_size: the file says " + std::to_string(p.width) + "x" + std::to_string(p.height) +
                ", got " + std::to_string(options.image_size->first) + "x" +
                std::to_string(options.image_size->second));
  }
  p = validated(std::move(p), source_name);
  if (info) {
    info->format = format;
    info->camera_name = chosen.name;
    info->camera_index = int(index);
    info->camera_count = int(cameras.size());
    info->notes = chosen.notes;
    if (cameras.size() > 1 && !options.camera) {
      info->notes.push_back("the file has " + std::to_string(cameras.size()) + " cameras; read the first (" +
                            text_for_message(chosen.name) + "); choose another by name or index");
    }
  }
  return p;
}

CameraParameters parse_camera(std::string_view content, std::string_view source_name,
                              std::optional<CameraFormat> format) {
  CameraReadOptions options;
  options.format = format;
  return parse_camera(content, source_name, options);
}

Camera read_camera(const std::filesystem::path& path, CameraFormat* format) {
  return read_camera(path, CameraReadOptions{}, format);
}

Camera read_camera(const std::filesystem::path& path, const CameraReadOptions& options, CameraFormat* format) {
  CameraFileInfo info;
  Camera camera = read_camera(path, options, &info);
  if (format) *format = info.format;
  return camera;
}

Camera read_camera(const std::filesystem::path& path, const CameraReadOptions& options, CameraFileInfo* info) {
  return Camera(parse_camera(read_camera_file(path), path_for_message(path), options, info));
}

namespace {

// What the calibration's data support, beside the model's own domain: the observed
// angles, the field of view they span along the image axes, and what of the
// model's domain and field of view exists only in extrapolation.
json observed_json(const Camera& camera) {
  constexpr double kToDeg = 180 / std::numbers::pi;
  const CameraParameters& p = camera.parameters();
  const CalibrationRecord& r = *p.calibration;
  const auto number = [](double v) { return std::isnan(v) ? json(nullptr) : json(v); };
  json sectors = json::array();
  for (double a : r.theta_max_by_azimuth) sectors.push_back(number(a * kToDeg));
  const double pi = std::numbers::pi;
  const double horizontal =
      (angle_near_azimuth(r.theta_max_by_azimuth, 0) + angle_near_azimuth(r.theta_max_by_azimuth, pi)) * kToDeg;
  const double vertical =
      (angle_near_azimuth(r.theta_max_by_azimuth, pi / 2) + angle_near_azimuth(r.theta_max_by_azimuth, -pi / 2)) *
      kToDeg;
  json extrapolated = json::array();
  const auto fov = camera.field_of_view_deg();
  char text[240];
  const double observed_deg = r.theta_max * kToDeg;
  for (const auto& [name, model_fov, data_fov] :
       {std::tuple{"horizontal", fov.horizontal, horizontal}, std::tuple{"vertical", fov.vertical, vertical}}) {
    if (std::isnan(data_fov) || model_fov > data_fov + 1.0) {
      std::snprintf(text, sizeof text,
                    "the %s field of view (%.1f deg) reaches beyond the %s deg the calibration's corners span", name,
                    model_fov, std::isnan(data_fov) ? "none" : std::to_string(int(std::lround(data_fov))).c_str());
      extrapolated.push_back(text);
    }
  }
  // The model's own domain, without a user limit: a fold past the observed angles is
  // the fit's extrapolation, not the lens.
  CameraParameters unlimited = p;
  unlimited.theta_limit.reset();
  unlimited.theta_limit_by_azimuth.reset();
  const ValidDomain model_domain = Camera(unlimited).domain();
  if (model_domain.limited_by == ValidDomain::Limit::fold && model_domain.theta_max > r.theta_max) {
    std::snprintf(text, sizeof text,
                  "the model folds at theta = %.1f deg (rho = %.1f px), beyond the observed %.1f deg: pixels past it "
                  "have no ray although the lens may see there",
                  model_domain.theta_max * kToDeg, model_domain.rho_max, observed_deg);
    extrapolated.push_back(text);
  } else if (camera.domain().theta_max > r.theta_max + 1e-9) {
    std::snprintf(text, sizeof text, "the valid domain (theta up to %.1f deg) reaches beyond the observed %.1f deg",
                  camera.domain().theta_max * kToDeg, observed_deg);
    extrapolated.push_back(text);
  }
  return {{"theta_max_deg", observed_deg},
          {"theta_max_by_azimuth_deg", sectors},
          {"fov_deg", {{"horizontal", number(horizontal)}, {"vertical", number(vertical)}}},
          {"has_covariance", r.covariance.size() > 0},
          {"extrapolated", extrapolated}};
}

}  // namespace

std::string camera_info_json(const Camera& camera, std::optional<CameraFormat> format) {
  constexpr double kToDeg = 180 / std::numbers::pi;
  const auto& p = camera.parameters();
  const auto& d = camera.domain();
  const auto fov = camera.field_of_view_deg();
  json j = {
      {"format", format ? json(to_string(*format)) : json(nullptr)},
      {"model", model_name(p.model)},
      {"parameters", model_params(p.model)},
      {"width", p.width},
      {"height", p.height},
      {"cx", p.grid.principal_point.x()},
      {"cy", p.grid.principal_point.y()},
      {"pixel_scale", {p.grid.pixel_scale.x(), p.grid.pixel_scale.y()}},
      {"theta_max_deg", d.theta_max * kToDeg},
      {"theta_max_closed", d.closed},
      {"theta_max_limited_by", to_string(d.limited_by)},
      {"theta_limit_by_azimuth_deg", nullptr},
      {"rho_max_px", d.closed ? json(d.rho_max) : json(nullptr)},
      {"fov_deg", {{"horizontal", fov.horizontal}, {"vertical", fov.vertical}, {"diagonal", fov.diagonal}}},
      {"inverse_table",
       {{"cells", camera.inverse_table().cells()},
        {"fallback_cells", camera.inverse_table().fallback_cells()},
        {"worst_error_px", camera.inverse_table().worst_error_px()},
        // Without a table (an open domain): a closed form, or the robust solver per point.
        {"closed_form",
         std::visit([](const auto& m) { return ClosedFormInverse<std::decay_t<decltype(m)>>; }, p.model)}}},
  };
  const MrcalLens* lens = p.mrcal_lens();
  j["mrcal_lens"] = lens ? json{{"lensmodel", lens->lensmodel()},
                                {"base_model", lens->base_model()},
                                {"values", lens->values().size()}}
                         : json(nullptr);
  j["tangential"] = nullptr;  // radially symmetric
  if (const TangentialTerms terms = p.tangential_terms(); terms.any()) {
    for (size_t i = 0; i < TangentialTerms::kNames.size(); ++i) {
      j["tangential"][std::string(TangentialTerms::kNames[i])] = terms.values()[i];
    }
  }
  if (p.theta_limit_by_azimuth) {
    for (double a : *p.theta_limit_by_azimuth) j["theta_limit_by_azimuth_deg"].push_back(a * kToDeg);
  }
  j["skew"] = p.grid.skew.any() ? json{{"xy", p.grid.skew.xy}, {"yx", p.grid.skew.yx}} : json(nullptr);
  if (p.pose) {
    const auto& q = p.pose->rotation;
    const auto& t = p.pose->translation;
    j["pose"] = {{"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}}, {"translation", {t.x(), t.y(), t.z()}}};
  }
  j["observed"] = p.calibration ? observed_json(camera) : json(nullptr);
  return j.dump();
}

bool camera_format_holds_calibration_record(CameraFormat format) {
  return format_spec(format).holds.calibration_record;
}

std::vector<std::string> camera_format_models(CameraFormat format) {
  const auto& listed = format_spec(format).models;
  std::vector<std::string> out;
  for (std::string_view name : listed.empty() ? model_names() : listed) out.emplace_back(name);
  return out;
}

namespace {
// "F1, F2" : the formats whose spec says yes.
template <class Predicate>
std::string formats_that(const Predicate& holds) {
  std::string names;
  for (const auto* s : detail::format_table()) {
    if (holds(*s)) names += std::string(names.empty() ? "" : ", ") + std::string(s->name);
  }
  return names;
}
// "" when the format holds the camera's user limit on the valid domain, else why not.
std::string cannot_hold_limit(const detail::FormatSpec& spec, const CameraParameters& camera) {
  if (spec.holds.theta_limit || !(camera.theta_limit || camera.theta_limit_by_azimuth)) return "";
  const auto holders = formats_that([](const detail::FormatSpec& s) { return s.holds.theta_limit; });
  return camera.theta_limit_by_azimuth
             ? "theta_limit_by_azimuth: the " + std::string(spec.name) +
                   " format cannot store a per-azimuth field-of-view limit (" + holders + " can)"
             : "theta_limit: the " + std::string(spec.name) + " format cannot store a user field-of-view limit (" +
                   holders + " can)";
}
// "" when the format holds the camera's non-radial parts, else why not.
std::string cannot_hold_non_radial(const detail::FormatSpec& spec, const CameraParameters& camera) {
  if (std::string why = spec.cannot_hold_distortion(camera.distortion); !why.empty()) return why;
  if (camera.grid.skew.any() && !spec.holds.skew) {
    return "skew: the " + std::string(spec.name) + " format cannot hold a skewed pixel grid (" +
           formats_that([](const detail::FormatSpec& s) { return s.holds.skew; }) + " can)";
  }
  // A format that stores a_x as it is holds its sign; the others store f = fx.
  if (camera.grid.is_mirrored() && !spec.holds.pixel_scale) {
    return "pixel_scale: the " + std::string(spec.name) +
           " format cannot hold a mirrored pixel grid (a_x or a_y < 0: " + "the camera of a flipped image; " +
           formats_that([](const detail::FormatSpec& s) { return s.holds.pixel_scale; }) + " can)";
  }
  return "";
}
}  // namespace

bool camera_format_holds(CameraFormat format, const PlaneDistortion& distortion) {
  return format_spec(format).cannot_hold_distortion(distortion).empty();
}

std::string format_camera(const CameraParameters& camera, CameraFormat format) {
  Camera check(camera);  // never write a camera we would refuse to read
  const detail::FormatSpec& spec = format_spec(format);
  // What a format holds is checked here, once, from its list: writers see only
  // cameras of their models.
  if (const std::string why = cannot_hold_limit(spec, camera); !why.empty()) throw Error(why);
  if (!spec.holds_model(model_name(camera.model))) detail::cannot_hold(camera, format);
  if (const std::string why = cannot_hold_non_radial(spec, camera); !why.empty()) throw Error(why);
  CameraParameters written = spec.holds.pixel_scale ? camera : detail::with_unit_ax(camera);
  if (!spec.holds.calibration_record) written.calibration.reset();
  std::string content = spec.write(written);
  // Nor a file our own reader refuses (a value that overflows in the format's
  // parameterisation, say): read it back before anyone can write it.
  try {
    CameraReadOptions options;
    options.format = format;
    options.image_size = std::pair{camera.width, camera.height};
    const CameraParameters back = parse_camera(content, "", options);
    if (!same_distortion(back.distortion, camera.distortion)) {
      throw Error(": its " + std::string(distortion_name(camera.distortion)) + " part does not read back");
    }
    // A format may hold the skew in another unit (BoofCV: skew = xy fx): a few ulps.
    const auto near = [](double a, double b) { return std::abs(a - b) <= 1e-13 * std::abs(b); };
    if (!near(back.grid.skew.xy, camera.grid.skew.xy) || !near(back.grid.skew.yx, camera.grid.skew.yx)) {
      throw Error(": its skew does not read back");
    }
  } catch (const Error& e) {
    std::string why = e.what();
    if (why.rfind(": ", 0) == 0) why = why.substr(2);
    throw Error("the " + std::string(to_string(format)) + " format cannot hold this camera (" + why + ")");
  }
  return content;
}

bool camera_format_holds_rig(CameraFormat format) { return format_spec(format).write_rig != nullptr; }

std::string format_rig(const std::vector<CameraParameters>& cameras, CameraFormat format) {
  const detail::FormatSpec& spec = format_spec(format);
  if (!spec.write_rig) {
    std::string holders;
    for (const auto* s : detail::format_table()) {
      if (s->write_rig) holders += std::string(holders.empty() ? "" : ", ") + std::string(s->name);
    }
    throw Error("the " + std::string(spec.name) + " format holds one camera, not a rig (rigs: " + holders + ")");
  }
  if (cameras.empty()) throw Error("a rig needs at least one camera");
  std::vector<CameraParameters> written;
  for (size_t i = 0; i < cameras.size(); ++i) {
    const CameraParameters& camera = cameras[i];
    Camera check(camera);
    const std::string which = "camera " + std::to_string(i) + ": ";
    if (!camera.pose) throw Error(which + "a rig camera needs its pose relative to camera 0");
    if (const std::string why = cannot_hold_limit(spec, camera); !why.empty()) throw Error(which + why);
    if (const std::string why = cannot_hold_non_radial(spec, camera); !why.empty()) throw Error(which + why);
    if (!spec.holds_model(model_name(camera.model))) {
      try {
        detail::cannot_hold(camera, format);
      } catch (const Error& e) {
        throw Error(which + e.what());
      }
    }
    CameraParameters w = spec.holds.pixel_scale ? camera : detail::with_unit_ax(camera);
    if (!spec.holds.calibration_record) w.calibration.reset();
    written.push_back(std::move(w));
  }
  std::string content = spec.write_rig(written);
  for (size_t i = 0; i < cameras.size(); ++i) {  // every camera reads back
    CameraReadOptions options;
    options.format = format;
    options.camera = std::to_string(i);
    try {
      parse_camera(content, "", options);
    } catch (const Error& e) {
      throw Error("the " + std::string(to_string(format)) + " format cannot hold camera " + std::to_string(i) +
                  " of this rig (" + e.what() + ")");
    }
  }
  return content;
}

void write_rig(const std::vector<CameraParameters>& cameras, const std::filesystem::path& path, CameraFormat format,
               bool overwrite) {
  write_file_atomically(path, format_rig(cameras, format), overwrite);
}

void write_camera(const CameraParameters& camera, const std::filesystem::path& path, CameraFormat format,
                  bool overwrite) {
  write_file_atomically(path, format_camera(camera, format), overwrite);
}

}  // namespace fishcam
