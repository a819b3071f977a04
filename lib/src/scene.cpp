#include "fishcam/scene.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace fishcam {
namespace {

namespace wc = woodscape_class;
constexpr double kInf = std::numeric_limits<double>::infinity();

enum class Material { road, sidewalk, curb, paint, body, person, pole, sign, facade };

struct Box {
  Eigen::Vector3d lo, hi;
  std::uint8_t label;
  Material material;
  cv::Vec3b colour;
};

struct Cylinder {  // vertical
  double x, y, radius, z0, z1;
  std::uint8_t label;
  Material material;
  cv::Vec3b colour;
};

struct Hit {
  double distance = kInf;
  Eigen::Vector3d point;
  std::uint8_t label = wc::background;
  Material material = Material::facade;
  cv::Vec3b colour;
  bool sky = true;
};

// Deterministic value noise in [0, 1) for integer cells.
double cell_noise(long a, long b) {
  std::uint64_t h = std::uint64_t(a) * 0x9E3779B97F4A7C15ull ^ (std::uint64_t(b) + 0x632BE59BD9B4E019ull);
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return double(h >> 11) * 0x1.0p-53;
}

// The scene, vehicle frame. The camera sits about 3.7 m ahead of the rear axle,
// 0.66 m up (the WoodScape front camera); everything is laid out around it.
struct Scene {
  std::vector<Box> boxes;
  std::vector<Cylinder> cylinders;

  Scene() {
    const cv::Vec3b curb_grey(185, 185, 180);
    boxes.push_back({{-60, 5.25, 0}, {120, 5.5, 0.15}, wc::curb, Material::curb, curb_grey});
    boxes.push_back({{-60, -5.5, 0}, {120, -5.25, 0.15}, wc::curb, Material::curb, curb_grey});
    // Vehicles (one a truck).
    boxes.push_back({{10, -3.4, 0}, {14.5, -1.6, 1.5}, wc::vehicle, Material::body, {40, 40, 170}});
    boxes.push_back({{6.5, 1.6, 0}, {11, 3.4, 1.45}, wc::vehicle, Material::body, {160, 110, 30}});
    boxes.push_back({{16, 6.2, 0}, {20.5, 8.0, 1.5}, wc::vehicle, Material::body, {60, 140, 60}});
    boxes.push_back({{25, -3.6, 0}, {34, -1.2, 3.2}, wc::vehicle, Material::body, {200, 200, 210}});
    // A motorcycle with its rider, a bicycle.
    boxes.push_back({{14, 2.0, 0}, {16, 2.6, 1.05}, wc::motorcycle, Material::body, {20, 20, 20}});
    cylinders.push_back({15.1, 2.3, 0.3, 0.9, 1.85, wc::rider, Material::person, {30, 90, 200}});
    boxes.push_back({{8.8, 6.9, 0}, {10.6, 7.1, 1.05}, wc::bicycle, Material::body, {0, 200, 230}});
    // People.
    cylinders.push_back({7.5, 6.4, 0.28, 0, 1.75, wc::person, Material::person, {120, 60, 160}});
    cylinders.push_back({12.0, -6.8, 0.28, 0, 1.8, wc::person, Material::person, {60, 160, 200}});
    cylinders.push_back({5.2, -6.1, 0.26, 0, 1.65, wc::person, Material::person, {200, 120, 90}});
    // Poles (background) with signs.
    for (const auto& [x, y] : {std::pair{8.5, -6.2}, std::pair{18.0, 6.0}}) {
      cylinders.push_back({x, y, 0.06, 0, 3.2, wc::background, Material::pole, {140, 140, 140}});
      boxes.push_back({{x - 0.05, y - 0.4, 2.4}, {x + 0.05, y + 0.4, 3.1}, wc::traffic_sign, Material::sign,
                       {30, 30, 220}});
    }
    // Buildings on both sides and across the end of the street.
    boxes.push_back({{-40, 12, 0}, {90, 20, 12}, wc::background, Material::facade, {120, 150, 190}});
    boxes.push_back({{-40, -20, 0}, {90, -12, 14}, wc::background, Material::facade, {170, 170, 150}});
    boxes.push_back({{90, -20, 0}, {100, 20, 16}, wc::background, Material::facade, {140, 120, 110}});
  }
};

const Scene& scene() {
  static const Scene s;
  return s;
}

void intersect_box(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& w, Hit* hit) {
  double t0 = 0, t1 = hit->distance;
  for (int k = 0; k < 3; ++k) {
    const double inv = 1 / w[k];
    double ta = (b.lo[k] - o[k]) * inv, tb = (b.hi[k] - o[k]) * inv;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (!(t0 <= t1)) return;
  }
  if (t0 <= 0 || t0 >= hit->distance) return;
  *hit = {t0, o + t0 * w, b.label, b.material, b.colour, false};
}

void intersect_cylinder(const Cylinder& c, const Eigen::Vector3d& o, const Eigen::Vector3d& w, Hit* hit) {
  const double ox = o.x() - c.x, oy = o.y() - c.y;
  const double a = w.x() * w.x() + w.y() * w.y();
  if (a == 0) return;
  const double b = ox * w.x() + oy * w.y(), cc = ox * ox + oy * oy - c.radius * c.radius;
  const double disc = b * b - a * cc;
  if (disc < 0) return;
  const double t = (-b - std::sqrt(disc)) / a;  // the outside of the mantle
  if (t <= 0 || t >= hit->distance) return;
  const double z = o.z() + t * w.z();
  if (z < c.z0 || z > c.z1) return;
  *hit = {t, o + t * w, c.label, c.material, c.colour, false};
}

cv::Vec3b shade(const Hit& hit, const Eigen::Vector3d& w) {
  if (hit.sky) {  // a gradient with the elevation
    const double e = std::clamp(w.z(), 0.0, 1.0);
    return {uchar(230 - 40 * e), uchar(200 - 60 * e), uchar(170 - 90 * e)};
  }
  const Eigen::Vector3d& p = hit.point;
  auto scaled = [](cv::Vec3b c, double f) {
    return cv::Vec3b(cv::saturate_cast<uchar>(c[0] * f), cv::saturate_cast<uchar>(c[1] * f),
                     cv::saturate_cast<uchar>(c[2] * f));
  };
  switch (hit.material) {
    case Material::road: {
      const double n = cell_noise(long(std::floor(p.x() * 4)), long(std::floor(p.y() * 4)));
      const uchar g = uchar(70 + 35 * n);
      return {g, g, uchar(g + 4)};
    }
    case Material::paint: return {235, 235, 235};
    case Material::sidewalk: {
      const bool tile = (long(std::floor(p.x())) + long(std::floor(p.y()))) % 2 == 0;
      return tile ? cv::Vec3b(150, 165, 175) : cv::Vec3b(120, 135, 150);
    }
    case Material::curb: return long(std::floor(p.x() * 2)) % 2 == 0 ? hit.colour : scaled(hit.colour, 0.8);
    case Material::body: return p.z() > 1.0 ? scaled(hit.colour, 0.45) : hit.colour;  // windows
    case Material::person: return p.z() > 0.9 ? hit.colour : scaled(hit.colour, 0.5);
    case Material::pole: return hit.colour;
    case Material::sign: {
      const bool border = std::abs(p.z() - 2.75) > 0.28;
      return border ? cv::Vec3b(240, 240, 240) : hit.colour;
    }
    case Material::facade: {
      const bool window = std::fmod(std::abs(p.z()), 3.0) > 1.2 &&
                          std::fmod(std::abs(p.x() + p.y()), 4.0) > 1.5;
      const double n = 0.85 + 0.3 * cell_noise(long(std::floor(p.x())), long(std::floor(p.z())));
      return window ? cv::Vec3b(70, 60, 50) : scaled(hit.colour, n);
    }
  }
  return {0, 0, 0};
}

Hit trace(const Eigen::Vector3d& o, const Eigen::Vector3d& w) {
  Hit hit;
  if (w.z() < 0) {  // the ground: road with markings, sidewalk beyond the curbs
    const double t = -o.z() / w.z();
    const Eigen::Vector3d p = o + t * w;
    const double y = std::abs(p.y());
    if (y <= 5.25) {
      const bool centre = y < 0.075 && std::fmod(p.x() + 1000, 6.0) < 3.0;  // dashed
      const bool edge = std::abs(y - 4.9) < 0.075;
      const bool paint = centre || edge;
      hit = {t, p, paint ? wc::lane_marking : wc::road, paint ? Material::paint : Material::road, {}, false};
    } else {
      hit = {t, p, wc::background, Material::sidewalk, {}, false};
    }
  }
  for (const Box& b : scene().boxes) intersect_box(b, o, w, &hit);
  for (const Cylinder& c : scene().cylinders) intersect_cylinder(c, o, w, &hit);
  return hit;
}

}  // namespace

std::string_view woodscape_class_name(int label) {
  static constexpr std::string_view names[] = {"background", "road",    "lane marking", "curb",       "person",
                                               "rider",      "vehicle", "bicycle",      "motorcycle", "traffic sign"};
  return label >= 0 && label < wc::kCount ? names[label] : "unknown";
}

cv::Vec3b woodscape_class_colour(int label) {
  static const cv::Vec3b colours[] = {{0, 0, 0},     {128, 64, 128}, {255, 255, 255}, {0, 200, 255}, {60, 20, 220},
                                      {0, 0, 255},   {142, 0, 0},    {32, 11, 119},   {230, 0, 0},   {0, 220, 220}};
  return label >= 0 && label < wc::kCount ? colours[label] : cv::Vec3b(255, 0, 255);
}

SceneRender render_street_scene(const Camera& camera, const Pose& camera_to_vehicle) {
  const int w = camera.width(), h = camera.height();
  std::vector<float> rays(3 * size_t(w) * size_t(h));
  camera.unproject_image(rays, InversePath::table);
  SceneRender out{cv::Mat(h, w, CV_8UC3), cv::Mat(h, w, CV_8UC1), cv::Mat(h, w, CV_32FC1)};
  const Eigen::Matrix3d r = camera_to_vehicle.rotation.toRotationMatrix();
  const Eigen::Vector3d o = camera_to_vehicle.translation;
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v) {
      for (int u = 0; u < w; ++u) {
        const float* d = &rays[3 * (size_t(v) * w + u)];
        if (std::isnan(d[0])) {
          out.image.at<cv::Vec3b>(v, u) = {0, 0, 0};
          out.labels.at<uchar>(v, u) = wc::background;
          out.range.at<float>(v, u) = std::numeric_limits<float>::quiet_NaN();
          continue;
        }
        const Eigen::Vector3d dir = (r * Eigen::Vector3d(d[0], d[1], d[2])).normalized();
        const Hit hit = trace(o, dir);
        out.image.at<cv::Vec3b>(v, u) = shade(hit, dir);
        out.labels.at<uchar>(v, u) = hit.label;
        out.range.at<float>(v, u) = float(hit.distance);
      }
    }
  });
  return out;
}

}  // namespace fishcam
