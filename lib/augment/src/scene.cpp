#include "fishcam/augment/scene.hpp"

#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

namespace fishcam {
namespace {

namespace wc = woodscape_class;
constexpr double kInf = std::numeric_limits<double>::infinity();

enum class Material { road, sidewalk, curb, paint, body, person, pole, sign, facade };

// A box in its own frame [lo, hi], placed at `origin` and turned by `yaw` about z.
struct Box {
  Eigen::Vector3d lo, hi;
  std::uint8_t label;
  Material material;
  cv::Vec3b colour;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  double yaw = 0;
  // Material details: body: windows above this height; facade: storey height and
  // window spacing; sign: the plate's border share.
  double detail_a = 1.0, detail_b = 4.0;
  double cos_yaw = 1, sin_yaw = 0;  // of yaw, set once per scene (with_trigonometry): rays test boxes per pixel
};

struct Cylinder {  // vertical
  double x, y, radius, z0, z1;
  std::uint8_t label;
  Material material;
  cv::Vec3b colour;
  double detail_a = 0.9;  // person: the upper body's colour above this height
};

// The road: centre line y = offset + curvature x^2 / 2; d, a point's offset from
// it across the road (positive to the left), decides what the ground is.
struct Road {
  double offset = 0, curvature = 0;
  double lane_width = 5.25;
  int lanes_per_side = 1;
  double parking_width = 0;  // between the outer lane and the curb
  double curb_width = 0;     // a flat curb strip (the bundled street's curbs are boxes)
  enum class Line { none, solid, dashed };
  Line centre = Line::dashed, lanes = Line::dashed;
  bool edges = true;
  double edge_inset = 0.35;  // edge line inside the lanes' outer boundary
  double dash = 3, gap = 3, line_half_width = 0.075;
  double road_grey = 70, road_grain = 35;
  cv::Vec3b tile_a{150, 165, 175}, tile_b{120, 135, 150};
  double half_width() const { return lanes_per_side * lane_width + parking_width; }
  double centre_y(double x) const { return offset + curvature * x * x / 2; }
  double across(const Eigen::Vector3d& p) const {
    const double slope = curvature * p.x();
    return (p.y() - centre_y(p.x())) / std::sqrt(1 + slope * slope);
  }
};

struct Light {
  cv::Vec3b sky_horizon{230, 200, 170}, sky_zenith{190, 140, 80};
  double brightness = 1;
  Eigen::Vector3d sun = Eigen::Vector3d::UnitZ();
  double sun_strength = 0;  // 0: flat colours (the bundled street)
};

struct Hit {
  double distance = kInf;
  Eigen::Vector3d point;  // world
  Eigen::Vector3d local;  // the object's frame (boxes), else world
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  std::uint8_t label = wc::background;
  Material material = Material::facade;
  cv::Vec3b colour;
  bool sky = true;
  double detail_a = 0, detail_b = 0;
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();  // the box's extent (signs)
};

// Deterministic value noise in [0, 1) for integer cells.
double cell_noise(long a, long b) {
  std::uint64_t h = std::uint64_t(a) * 0x9E3779B97F4A7C15ull ^ (std::uint64_t(b) + 0x632BE59BD9B4E019ull);
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return double(h >> 11) * 0x1.0p-53;
}

}  // namespace

struct StreetScene::Content {
  std::vector<Box> boxes;
  std::vector<Cylinder> cylinders;
  Road road;
  Light light;
};

namespace {

// The bundled street, vehicle frame. The camera sits about 3.7 m ahead of the rear
// axle, 0.66 m up (the WoodScape front camera); everything is laid out around it.
StreetScene::Content bundled_content() {
  StreetScene::Content s;
  auto& boxes = s.boxes;
  auto& cylinders = s.cylinders;
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
    boxes.push_back({{x - 0.05, y - 0.4, 2.4},
                     {x + 0.05, y + 0.4, 3.1},
                     wc::traffic_sign,
                     Material::sign,
                     {30, 30, 220},
                     Eigen::Vector2d::Zero(),
                     0,
                     0.2});
  }
  // Buildings on both sides and across the end of the street.
  boxes.push_back({{-40, 12, 0}, {90, 20, 12}, wc::background, Material::facade, {120, 150, 190}, {0, 0}, 0, 3.0, 4.0});
  boxes.push_back(
      {{-40, -20, 0}, {90, -12, 14}, wc::background, Material::facade, {170, 170, 150}, {0, 0}, 0, 3.0, 4.0});
  boxes.push_back(
      {{90, -20, 0}, {100, 20, 16}, wc::background, Material::facade, {140, 120, 110}, {0, 0}, 0, 3.0, 4.0});
  return s;
}

// Uniform numbers from mt19937_64's raw output (specified bit for bit by the
// standard, unlike the std distributions), so a seed gives the same scene everywhere.
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : engine_(seed ^ 0x5CE7E5EEDull) {}
  double uniform(double lo, double hi) { return lo + (hi - lo) * double(engine_() >> 11) * 0x1.0p-53; }
  int integer(int lo, int hi) { return std::min(hi, lo + int(uniform(0, hi - lo + 1))); }  // [lo, hi]
  bool chance(double p) { return uniform(0, 1) < p; }
  cv::Vec3b colour(int lo, int hi) { return {uchar(integer(lo, hi)), uchar(integer(lo, hi)), uchar(integer(lo, hi))}; }

 private:
  std::mt19937_64 engine_;
};

// Places boxes and cylinders along the road: station x, offset d across it.
struct Layout {
  StreetScene::Content* scene;
  Draw* draw;
  std::vector<std::array<double, 4>> taken;  // footprints (x0, y0, x1, y1), world, padded

  Eigen::Vector2d at(double x, double d) const {
    const double yaw = heading(x);
    return {x - d * std::sin(yaw), scene->road.centre_y(x) + d * std::cos(yaw)};
  }
  double heading(double x) const { return std::atan(scene->road.curvature * x); }
  // Whether a footprint of half-extents (a, b) at p turned by yaw is free; if so, taken.
  bool claim(const Eigen::Vector2d& p, double yaw, double a, double b, double pad = 0.3) {
    const double ex = std::abs(a * std::cos(yaw)) + std::abs(b * std::sin(yaw)) + pad;
    const double ey = std::abs(a * std::sin(yaw)) + std::abs(b * std::cos(yaw)) + pad;
    const std::array<double, 4> f{p.x() - ex, p.y() - ey, p.x() + ex, p.y() + ey};
    for (const auto& t : taken) {
      if (f[0] < t[2] && t[0] < f[2] && f[1] < t[3] && t[1] < f[3]) return false;
    }
    taken.push_back(f);
    return true;
  }
  // A box of size (length, width, height) standing at station x, offset d, along the road.
  bool box(double x, double d, double length, double width, double height, std::uint8_t label, Material material,
           cv::Vec3b colour, double detail_a = 1.0, double detail_b = 4.0, double z0 = 0, double yaw_jitter = 0) {
    const Eigen::Vector2d p = at(x, d);
    const double yaw = heading(x) + yaw_jitter;
    if (z0 == 0 && !claim(p, yaw, length / 2, width / 2)) return false;
    scene->boxes.push_back({{-length / 2, -width / 2, z0},
                            {length / 2, width / 2, z0 + height},
                            label,
                            material,
                            colour,
                            p,
                            yaw,
                            detail_a,
                            detail_b});
    return true;
  }
};

// The road's lanes, markings and surfaces.
void draw_road(Draw& draw, Road& road) {
  road.lanes_per_side = draw.integer(1, 2);
  road.lane_width = draw.uniform(2.8, 3.7);
  road.parking_width = draw.chance(0.6) ? draw.uniform(2.0, 2.5) : 0.0;
  road.curb_width = draw.uniform(0.2, 0.35);
  road.offset = road.lane_width / 2;  // the ego vehicle drives in the first lane right of the centre line
  road.curvature = draw.chance(0.3) ? 0.0 : draw.uniform(-1 / 180.0, 1 / 180.0);
  road.centre = draw.chance(0.6) ? Road::Line::dashed : Road::Line::solid;
  road.lanes = Road::Line::dashed;
  road.edges = draw.chance(0.7);
  road.edge_inset = 0.25;
  road.dash = draw.uniform(2, 4), road.gap = draw.uniform(3, 7);
  road.line_half_width = draw.uniform(0.06, 0.1);
  road.road_grey = draw.uniform(50, 95), road.road_grain = draw.uniform(15, 40);
  road.tile_a = draw.colour(110, 190), road.tile_b = draw.colour(90, 160);
}

// The sky's colours and the sun.
void draw_light(Draw& draw, Light& light) {
  light.sky_horizon = {uchar(draw.integer(200, 245)), uchar(draw.integer(180, 225)), uchar(draw.integer(150, 210))};
  light.sky_zenith = {uchar(draw.integer(150, 230)), uchar(draw.integer(100, 170)), uchar(draw.integer(40, 120))};
  light.brightness = draw.uniform(0.75, 1.15);
  const double sun_azimuth = draw.uniform(-std::numbers::pi, std::numbers::pi), sun_elevation = draw.uniform(0.3, 1.2);
  light.sun = {std::cos(sun_elevation) * std::cos(sun_azimuth), std::cos(sun_elevation) * std::sin(sun_azimuth),
               std::sin(sun_elevation)};
  light.sun_strength = draw.uniform(0.2, 0.6);
}

// The street across its length: where the lanes end (|d| = lanes), where the sidewalk
// begins (kerb) and its width.
struct Street {
  double lanes, kerb, sidewalk;
};

// Parked vehicles along both curbs and moving ones in every lane.
void place_vehicles(Layout& layout, const Street& street) {
  Draw& draw = *layout.draw;
  const Road& road = layout.scene->road;
  const double lanes = street.lanes;
  const cv::Vec3b palette[] = {{40, 40, 170},   {160, 110, 30}, {60, 140, 60},   {200, 200, 210}, {30, 30, 30},
                               {230, 230, 230}, {20, 90, 200},  {120, 120, 120}, {60, 30, 110},   {0, 150, 220}};
  const auto vehicle_colour = [&] {
    cv::Vec3b c = palette[draw.integer(0, 9)];
    for (int k = 0; k < 3; ++k) c[k] = cv::saturate_cast<uchar>(c[k] + draw.integer(-20, 20));
    return c;
  };
  const auto vehicle = [&](double x, double d, double yaw_jitter) {
    const double kind = draw.uniform(0, 1);
    double length, width, height;
    if (kind < 0.65) {
      length = draw.uniform(3.9, 4.9), width = draw.uniform(1.7, 1.9), height = draw.uniform(1.4, 1.6);
    } else if (kind < 0.88) {
      length = draw.uniform(4.8, 5.6), width = draw.uniform(1.9, 2.1), height = draw.uniform(1.9, 2.4);
    } else {
      length = draw.uniform(7.0, 12.0), width = draw.uniform(2.4, 2.6), height = draw.uniform(2.8, 3.4);
    }
    layout.box(x, d, length, width, height, wc::vehicle, Material::body, vehicle_colour(), 0.65 * height, 4.0, 0,
               yaw_jitter);
  };
  // Parked vehicles along both curbs, where there is a parking strip.
  if (road.parking_width > 0) {
    for (const double side : {-1.0, 1.0}) {
      for (double x = -45 + draw.uniform(0, 4); x < 90; x += draw.uniform(6.0, 11.0)) {
        if (draw.chance(0.55)) vehicle(x, side * (lanes + road.parking_width / 2), draw.uniform(-0.05, 0.05));
      }
    }
  }
  // Moving vehicles in every lane.
  for (int lane = -road.lanes_per_side; lane < road.lanes_per_side; ++lane) {
    const double d = (lane + 0.5) * road.lane_width;
    for (double x = -45 + draw.uniform(0, 10); x < 90; x += draw.uniform(10.0, 30.0)) {
      if (draw.chance(0.5)) vehicle(x, d, draw.uniform(-0.03, 0.03));
    }
  }
}

void place_riders(Layout& layout, const Street& street) {
  Draw& draw = *layout.draw;
  StreetScene::Content& s = *layout.scene;
  const double lanes = street.lanes;
  // Riders on bicycles and motorcycles near the lanes' outer edges.
  const int riders = draw.integer(1, 4);
  for (int i = 0, tries = 0; i < riders && tries < 40; ++tries) {
    const double side = draw.chance(0.5) ? -1.0 : 1.0, x = draw.uniform(-30, 60);
    const double d = side * (lanes - 0.9);
    const bool motorcycle = draw.chance(0.5);
    const double length = motorcycle ? 2.1 : 1.75, width = motorcycle ? 0.7 : 0.15, height = motorcycle ? 1.1 : 1.0;
    if (!layout.box(x, d, length, width, height, motorcycle ? wc::motorcycle : wc::bicycle, Material::body,
                    motorcycle ? draw.colour(10, 60) : draw.colour(0, 230), 10.0)) {
      continue;
    }
    const Eigen::Vector2d p = layout.at(x, d);
    s.cylinders.push_back({p.x(), p.y(), draw.uniform(0.24, 0.3), motorcycle ? 0.8 : 0.85, draw.uniform(1.65, 1.8),
                           wc::rider, Material::person, draw.colour(20, 220), 1.2});
    ++i;
  }
}

void place_persons(Layout& layout, const Street& street) {
  Draw& draw = *layout.draw;
  StreetScene::Content& s = *layout.scene;
  const double lanes = street.lanes, kerb = street.kerb, sidewalk = street.sidewalk;
  // Persons on the sidewalks (and one sometimes crossing).
  const int persons = draw.integer(3, 9);
  for (int i = 0, tries = 0; i < persons && tries < 60; ++tries) {
    const double side = draw.chance(0.5) ? -1.0 : 1.0;
    const bool crossing = i == 0 && draw.chance(0.3);
    const double x = draw.uniform(-25, 45);
    const double d = crossing ? draw.uniform(-lanes, lanes) : side * (kerb + draw.uniform(0.4, sidewalk - 0.4));
    const Eigen::Vector2d p = layout.at(x, d);
    const double radius = draw.uniform(0.22, 0.3), height = draw.uniform(1.5, 1.9);
    if (!layout.claim(p, 0, radius, radius, 0.2)) continue;
    s.cylinders.push_back(
        {p.x(), p.y(), radius, 0, height, wc::person, Material::person, draw.colour(20, 220), 0.52 * height});
    ++i;
  }
}

void place_signs(Layout& layout, const Street& street) {
  Draw& draw = *layout.draw;
  StreetScene::Content& s = *layout.scene;
  const double kerb = street.kerb;
  // Traffic signs on poles near the curbs.
  const int signs = draw.integer(2, 5);
  for (int i = 0, tries = 0; i < signs && tries < 40; ++tries) {
    const double side = draw.chance(0.5) ? -1.0 : 1.0, x = draw.uniform(-25, 60);
    const double d = side * (kerb + 0.5);
    const Eigen::Vector2d p = layout.at(x, d);
    if (!layout.claim(p, 0, 0.4, 0.4, 0.2)) continue;
    const double top = draw.uniform(2.6, 3.4), size = draw.uniform(0.55, 0.85);
    s.cylinders.push_back(
        {p.x(), p.y(), draw.uniform(0.05, 0.07), 0, top, wc::background, Material::pole, {140, 140, 140}});
    const cv::Vec3b sign_colours[] = {{30, 30, 220}, {200, 90, 20}, {20, 200, 230}, {40, 140, 40}};
    // The plate faces along the road (thin along it), just in front of the pole.
    s.boxes.push_back({{-0.04, -size / 2, top - size},
                       {0.04, size / 2, top},
                       wc::traffic_sign,
                       Material::sign,
                       sign_colours[draw.integer(0, 3)],
                       layout.at(x - 0.1, d),
                       layout.heading(x),
                       0.15});
    ++i;
  }
}

void place_buildings(Layout& layout, const Street& street) {
  Draw& draw = *layout.draw;
  StreetScene::Content& s = *layout.scene;
  const double kerb = street.kerb, sidewalk = street.sidewalk;
  // Buildings beyond the sidewalks, and far away across the street's ends.
  for (const double side : {-1.0, 1.0}) {
    for (double x = -60 + draw.uniform(0, 5); x < 110;) {
      const double length = draw.uniform(6, 20), depth = draw.uniform(6, 12), height = draw.uniform(5, 22);
      const cv::Vec3b colour = draw.colour(90, 210);
      s.boxes.push_back({{-length / 2, -depth / 2, 0},
                         {length / 2, depth / 2, height},
                         wc::background,
                         Material::facade,
                         colour,
                         layout.at(x + length / 2, side * (kerb + sidewalk + depth / 2)),
                         layout.heading(x + length / 2),
                         draw.uniform(2.8, 3.6),
                         draw.uniform(2.5, 4.5)});
      x += length + (draw.chance(0.3) ? draw.uniform(1, 4) : 0.0);
    }
  }
}

StreetScene::Content generated_content(std::uint64_t seed) {
  StreetScene::Content s;
  Draw draw(seed);
  draw_road(draw, s.road);
  draw_light(draw, s.light);
  Layout layout{&s, &draw, {}};
  layout.taken.push_back({-3.0, -2.2, 6.0, 2.2});  // the ego vehicle and its cameras
  const Road& road = s.road;
  const double kerb = road.half_width() + road.curb_width;  // where the sidewalk begins
  const Street street{road.lanes_per_side * road.lane_width, kerb, draw.uniform(2.0, 5.0)};
  place_vehicles(layout, street);
  place_riders(layout, street);
  place_persons(layout, street);
  place_signs(layout, street);
  place_buildings(layout, street);
  return s;
}

void intersect_box(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& w, Hit* hit) {
  Eigen::Vector3d lo = o, lw = w;  // the ray in the box's frame
  const double c = b.cos_yaw, sn = b.sin_yaw;
  if (b.yaw != 0 || b.origin.x() != 0 || b.origin.y() != 0) {
    const double x = o.x() - b.origin.x(), y = o.y() - b.origin.y();
    lo = {c * x + sn * y, -sn * x + c * y, o.z()};
    lw = {c * w.x() + sn * w.y(), -sn * w.x() + c * w.y(), w.z()};
  }
  double t0 = 0, t1 = hit->distance;
  int axis = 0;
  for (int k = 0; k < 3; ++k) {
    const double inv = 1 / lw[k];
    double ta = (b.lo[k] - lo[k]) * inv, tb = (b.hi[k] - lo[k]) * inv;
    if (ta > tb) std::swap(ta, tb);
    if (ta > t0) t0 = ta, axis = k;
    t1 = std::min(t1, tb);
    if (!(t0 <= t1)) return;
  }
  if (t0 <= 0 || t0 >= hit->distance) return;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  normal[axis] = lw[axis] > 0 ? -1 : 1;
  normal = Eigen::Vector3d(c * normal.x() - sn * normal.y(), sn * normal.x() + c * normal.y(), normal.z());
  *hit = {t0,       o + t0 * w, lo + t0 * lw, normal,     b.label, b.material,
          b.colour, false,      b.detail_a,   b.detail_b, b.lo,    b.hi};
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
  const Eigen::Vector3d p = o + t * w;
  const Eigen::Vector3d normal = Eigen::Vector3d(p.x() - c.x, p.y() - c.y, 0) / c.radius;
  *hit = {t, p, p, normal, c.label, c.material, c.colour, false, c.detail_a, 0};
}

cv::Vec3b scaled(cv::Vec3b c, double f) {
  return {cv::saturate_cast<uchar>(c[0] * f), cv::saturate_cast<uchar>(c[1] * f), cv::saturate_cast<uchar>(c[2] * f)};
}

cv::Vec3b albedo(const Hit& hit, const Road& road) {
  const Eigen::Vector3d& p = hit.local;
  switch (hit.material) {
    case Material::road: {
      const double n = cell_noise(long(std::floor(p.x() * 4)), long(std::floor(p.y() * 4)));
      const uchar g = uchar(road.road_grey + road.road_grain * n);
      return {g, g, cv::saturate_cast<uchar>(g + 4)};
    }
    case Material::paint:
      return {235, 235, 235};
    case Material::sidewalk: {
      const bool tile = (long(std::floor(p.x())) + long(std::floor(p.y()))) % 2 == 0;
      return tile ? road.tile_a : road.tile_b;
    }
    case Material::curb:
      return long(std::floor(p.x() * 2)) % 2 == 0 ? cv::Vec3b(185, 185, 180) : scaled({185, 185, 180}, 0.8);
    case Material::body:
      return p.z() > hit.detail_a ? scaled(hit.colour, 0.45) : hit.colour;  // windows
    case Material::person:
      return p.z() > hit.detail_a ? hit.colour : scaled(hit.colour, 0.5);
    case Material::pole:
      return hit.colour;
    case Material::sign: {  // a white border around the coloured plate
      const double cy = (hit.lo.y() + hit.hi.y()) / 2, hy = (hit.hi.y() - hit.lo.y()) / 2;
      const double cz = (hit.lo.z() + hit.hi.z()) / 2, hz = (hit.hi.z() - hit.lo.z()) / 2;
      const double inner = 1 - hit.detail_a;
      const bool border = std::abs(p.z() - cz) > inner * hz || (hy < 2 * hz && std::abs(p.y() - cy) > inner * hy);
      return border ? cv::Vec3b(240, 240, 240) : hit.colour;
    }
    case Material::facade: {
      const double along = std::abs(hit.normal.x()) > std::abs(hit.normal.y()) ? p.y() : p.x();
      const bool window = std::fmod(std::abs(p.z()), hit.detail_a) > 0.4 * hit.detail_a &&
                          std::fmod(std::abs(along + 1000), hit.detail_b) > 0.375 * hit.detail_b;
      const double n = 0.85 + 0.3 * cell_noise(long(std::floor(along)), long(std::floor(p.z())));
      return window ? cv::Vec3b(70, 60, 50) : scaled(hit.colour, n);
    }
  }
  return {0, 0, 0};
}

cv::Vec3b shade(const Hit& hit, const Eigen::Vector3d& w, const StreetScene::Content& scene) {
  const Light& light = scene.light;
  if (hit.sky) {  // a gradient with the elevation
    const double e = std::clamp(w.z(), 0.0, 1.0);
    cv::Vec3b c;
    for (int k = 0; k < 3; ++k) c[k] = uchar(light.sky_horizon[k] + (light.sky_zenith[k] - light.sky_horizon[k]) * e);
    return c;
  }
  const cv::Vec3b c = albedo(hit, scene.road);
  if (light.sun_strength == 0 && light.brightness == 1) return c;
  const double lambert = std::max(0.0, hit.normal.dot(light.sun));
  return scaled(c, light.brightness * (1 - light.sun_strength + 1.6 * light.sun_strength * lambert));
}

// What a ray hits: the ground (road with markings, curbs, sidewalks), then the
// objects in `candidates`.
Hit trace(const StreetScene::Content& scene, const std::vector<int>& candidates, const Eigen::Vector3d& o,
          const Eigen::Vector3d& w) {
  Hit hit;
  if (w.z() < 0) {
    const double t = -o.z() / w.z();
    const Eigen::Vector3d p = o + t * w;
    const Road& road = scene.road;
    const double d = road.across(p), y = std::abs(d);
    const double lanes = road.lanes_per_side * road.lane_width;
    if (y <= road.half_width()) {
      const auto on_line = [&](double at, Road::Line line) {
        if (line == Road::Line::none || std::abs(y - at) >= road.line_half_width) return false;
        return line == Road::Line::solid || std::fmod(p.x() + 1000, road.dash + road.gap) < road.dash;
      };
      bool paint = on_line(0, road.centre) || (road.edges && on_line(lanes - road.edge_inset, Road::Line::solid));
      for (int k = 1; k < road.lanes_per_side; ++k) paint = paint || on_line(k * road.lane_width, road.lanes);
      hit = {t,
             p,
             p,
             Eigen::Vector3d::UnitZ(),
             paint ? wc::lane_marking : wc::road,
             paint ? Material::paint : Material::road,
             {},
             false,
             0,
             0};
    } else if (y <= road.half_width() + road.curb_width) {
      hit = {t, p, p, Eigen::Vector3d::UnitZ(), wc::curb, Material::curb, {}, false, 0, 0};
    } else {
      hit = {t, p, p, Eigen::Vector3d::UnitZ(), wc::background, Material::sidewalk, {}, false, 0, 0};
    }
  }
  const int boxes = int(scene.boxes.size());
  for (const int i : candidates) {
    if (i < boxes) {
      intersect_box(scene.boxes[size_t(i)], o, w, &hit);
    } else {
      intersect_cylinder(scene.cylinders[size_t(i - boxes)], o, w, &hit);
    }
  }
  return hit;
}

// A sphere around each object (boxes first, then cylinders), for culling.
struct Bound {
  Eigen::Vector3d centre;
  double radius;
};

std::vector<Bound> bounds_of(const StreetScene::Content& scene) {
  std::vector<Bound> out;
  for (const Box& b : scene.boxes) {
    const Eigen::Vector3d mid = (b.lo + b.hi) / 2;
    const double c = b.cos_yaw, s = b.sin_yaw;
    out.push_back({{b.origin.x() + c * mid.x() - s * mid.y(), b.origin.y() + s * mid.x() + c * mid.y(), mid.z()},
                   (b.hi - b.lo).norm() / 2});
  }
  for (const Cylinder& c : scene.cylinders) {
    out.push_back({{c.x, c.y, (c.z0 + c.z1) / 2}, std::hypot(c.radius, (c.z1 - c.z0) / 2)});
  }
  return out;
}

// Traces a w x h grid of camera rays (NaN: outside the domain) in tiles: each tile
// tests only the objects whose bounding sphere meets the cone of its rays.
template <class PerPixel>
void trace_grid(const StreetScene::Content& scene, const std::vector<float>& rays, int w, int h,
                const Eigen::Matrix3d& rotation, const Eigen::Vector3d& origin, PerPixel&& per_pixel) {
  constexpr int kTile = 16;
  const std::vector<Bound> bounds = bounds_of(scene);
  const int tiles_x = (w + kTile - 1) / kTile, tiles_y = (h + kTile - 1) / kTile;
  cv::parallel_for_(cv::Range(0, tiles_x * tiles_y), [&](const cv::Range& range) {
    std::vector<Eigen::Vector3d> directions;
    std::vector<int> candidates;
    for (int tile = range.start; tile < range.end; ++tile) {
      const int u0 = (tile % tiles_x) * kTile, v0 = (tile / tiles_x) * kTile;
      const int u1 = std::min(w, u0 + kTile), v1 = std::min(h, v0 + kTile);
      directions.assign(size_t((u1 - u0) * (v1 - v0)), Eigen::Vector3d::Constant(std::nan("")));
      Eigen::Vector3d axis = Eigen::Vector3d::Zero();
      for (int v = v0; v < v1; ++v) {
        for (int u = u0; u < u1; ++u) {
          const float* d = &rays[3 * (size_t(v) * size_t(w) + size_t(u))];
          if (std::isnan(d[0])) continue;
          const Eigen::Vector3d dir = (rotation * Eigen::Vector3d(d[0], d[1], d[2])).normalized();
          directions[size_t((v - v0) * (u1 - u0) + (u - u0))] = dir;
          axis += dir;
        }
      }
      double spread = std::numbers::pi;  // the cone's half-angle; all directions when the rays spread widely
      if (axis.norm() > 1e-9) {
        axis.normalize();
        double cos_spread = 1;
        for (const auto& dir : directions) {
          if (!std::isnan(dir.x())) cos_spread = std::min(cos_spread, dir.dot(axis));
        }
        spread = std::acos(std::clamp(cos_spread, -1.0, 1.0));
      }
      candidates.clear();
      for (size_t i = 0; i < bounds.size(); ++i) {
        const Eigen::Vector3d to = bounds[i].centre - origin;
        const double distance = to.norm();
        if (distance <= bounds[i].radius || spread >= std::numbers::pi / 2) {
          candidates.push_back(int(i));
          continue;
        }
        const double angle = std::acos(std::clamp(to.dot(axis) / distance, -1.0, 1.0));
        if (angle <= spread + std::asin(bounds[i].radius / distance) + 1e-9) candidates.push_back(int(i));
      }
      for (int v = v0; v < v1; ++v) {
        for (int u = u0; u < u1; ++u) {
          const Eigen::Vector3d& dir = directions[size_t((v - v0) * (u1 - u0) + (u - u0))];
          if (std::isnan(dir.x())) {
            per_pixel(u, v, nullptr, dir);
          } else {
            const Hit hit = trace(scene, candidates, origin, dir);
            per_pixel(u, v, &hit, dir);
          }
        }
      }
    }
  });
}

}  // namespace

StreetScene::StreetScene(std::shared_ptr<const Content> content) : content_(std::move(content)) {}

namespace {

std::shared_ptr<const StreetScene::Content> with_trigonometry(StreetScene::Content content) {
  for (Box& b : content.boxes) b.cos_yaw = std::cos(b.yaw), b.sin_yaw = std::sin(b.yaw);
  return std::make_shared<const StreetScene::Content>(std::move(content));
}

}  // namespace

const StreetScene& StreetScene::bundled() {
  static const StreetScene scene(with_trigonometry(bundled_content()));
  return scene;
}

StreetScene StreetScene::generate(std::uint64_t scene_seed) {
  return StreetScene(with_trigonometry(generated_content(scene_seed)));
}

SceneRender StreetScene::render(const Camera& camera, const Pose& camera_to_vehicle, int supersampling) const {
  if (supersampling < 1 || supersampling > 4) {
    throw Error("render: supersampling must be 1 to 4, got " + std::to_string(supersampling));
  }
  const Content& scene = *content_;
  const int w = camera.width(), h = camera.height();
  const Eigen::Matrix3d r = camera_to_vehicle.rotation.toRotationMatrix();
  const Eigen::Vector3d o = camera_to_vehicle.translation;
  std::vector<float> rays(3 * size_t(w) * size_t(h));
  camera.unproject_image(rays, InversePath::table);
  SceneRender out{cv::Mat(h, w, CV_8UC3), cv::Mat(h, w, CV_8UC1), cv::Mat(h, w, CV_32FC1)};
  trace_grid(scene, rays, w, h, r, o, [&](int u, int v, const Hit* hit, const Eigen::Vector3d& dir) {
    out.labels.at<uchar>(v, u) = hit ? hit->label : std::uint8_t(wc::background);
    out.range.at<float>(v, u) = hit ? float(hit->distance) : std::numeric_limits<float>::quiet_NaN();
    if (supersampling == 1) out.image.at<cv::Vec3b>(v, u) = hit ? shade(*hit, dir, scene) : cv::Vec3b(0, 0, 0);
  });
  if (supersampling == 1) return out;
  // The RGB from the same lens at supersampling x the size (its pixel centres at the
  // sub-pixel offsets of the original's), averaged over each pixel's block.
  const int s = supersampling, sw = s * w, sh = s * h;
  const Camera fine(resized(camera.parameters(), sw, sh));
  std::vector<float> fine_rays(3 * size_t(sw) * size_t(sh));
  fine.unproject_image(fine_rays, InversePath::table);
  cv::Mat colours(sh, sw, CV_8UC3), valid(sh, sw, CV_8UC1);
  trace_grid(scene, fine_rays, sw, sh, r, o, [&](int u, int v, const Hit* hit, const Eigen::Vector3d& dir) {
    colours.at<cv::Vec3b>(v, u) = hit ? shade(*hit, dir, scene) : cv::Vec3b(0, 0, 0);
    valid.at<uchar>(v, u) = hit ? 1 : 0;
  });
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v) {
      for (int u = 0; u < w; ++u) {
        int sum[3] = {0, 0, 0}, count = 0;
        for (int j = 0; j < s; ++j) {
          for (int i = 0; i < s; ++i) {
            if (!valid.at<uchar>(s * v + j, s * u + i)) continue;
            const cv::Vec3b& c = colours.at<cv::Vec3b>(s * v + j, s * u + i);
            for (int k = 0; k < 3; ++k) sum[k] += c[k];
            ++count;
          }
        }
        cv::Vec3b& pixel = out.image.at<cv::Vec3b>(v, u);
        const bool inside = !std::isnan(out.range.at<float>(v, u));
        for (int k = 0; k < 3; ++k) pixel[k] = inside && count > 0 ? uchar((sum[k] + count / 2) / count) : uchar(0);
      }
    }
  });
  return out;
}

SceneRender render_street_scene(const Camera& camera, const Pose& camera_to_vehicle) {
  return StreetScene::bundled().render(camera, camera_to_vehicle);
}

std::string_view woodscape_class_name(int label) {
  static constexpr std::string_view names[] = {"background", "road",    "lane marking", "curb",       "person",
                                               "rider",      "vehicle", "bicycle",      "motorcycle", "traffic sign"};
  return label >= 0 && label < wc::kCount ? names[label] : "unknown";
}

cv::Vec3b woodscape_class_colour(int label) {
  static const cv::Vec3b colours[] = {{0, 0, 0},   {128, 64, 128}, {255, 255, 255}, {0, 200, 255}, {60, 20, 220},
                                      {0, 0, 255}, {142, 0, 0},    {32, 11, 119},   {230, 0, 0},   {0, 220, 220}};
  return label >= 0 && label < wc::kCount ? colours[label] : cv::Vec3b(255, 0, 255);
}

}  // namespace fishcam
