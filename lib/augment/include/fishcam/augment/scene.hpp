// Deterministic street scenes -- the bundled one and seeded random streets --
// ray-cast through any camera at any pose: the default input, test data, the
// experiment's dataset and ground truth for the augmentation.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <memory>
#include <string_view>

#include "fishcam/augment/viewpoint.hpp"
#include "fishcam/core/camera.hpp"

namespace fishcam {

// WoodScape's semantic classes (gtLabels values; 10 classes with background).
namespace woodscape_class {
enum : std::uint8_t {
  background = 0,
  road = 1,
  lane_marking = 2,
  curb = 3,
  person = 4,
  rider = 5,
  vehicle = 6,
  bicycle = 7,
  motorcycle = 8,
  traffic_sign = 9,
};
constexpr int kCount = 10;
}  // namespace woodscape_class

std::string_view woodscape_class_name(int label);
// A display colour (BGR) per class, for contact sheets.
cv::Vec3b woodscape_class_colour(int label);

struct SceneRender {
  cv::Mat image;   // CV_8UC3, BGR
  cv::Mat labels;  // CV_8UC1, WoodScape classes
  cv::Mat range;   // CV_32FC1, distance from the camera to the surface (m); +inf for the sky, NaN outside the domain
};

// A street scene in the vehicle frame of ISO 8855 (x forward, y left, z up; metres;
// the road at z = 0; the ego vehicle's rear axle at the origin), ray-cast through
// any camera at any pose. Labels and range come from one ray through each pixel
// centre, so they are exact; the RGB image averages supersampling^2 rays per pixel.
// Pixels outside the camera's valid domain are black, background, NaN range.
class StreetScene {
 public:
  // The bundled street: one fixed scene (render, compare and the tests draw it).
  static const StreetScene& bundled();
  // A street drawn from scene_seed: road width, lanes and curvature, solid or dashed
  // markings, curbs, sidewalks, parked and moving vehicles (cars, vans, trucks),
  // persons, riders on bicycles and motorcycles, signs on poles, buildings with
  // varied facades, sky and lighting. Every WoodScape class occurs, with its id;
  // the ego vehicle's footprint (and its cameras) stays clear. The same seed gives
  // the same scene (drawn from mt19937_64's output, which the standard fixes).
  static StreetScene generate(std::uint64_t scene_seed);

  // supersampling in [1, 4].
  SceneRender render(const Camera& camera, const Pose& camera_to_vehicle, int supersampling = 1) const;

  struct Content;  // the objects, the road, the light (scene.cpp)
  explicit StreetScene(std::shared_ptr<const Content> content);

 private:
  std::shared_ptr<const Content> content_;
};

// StreetScene::bundled().render(camera, camera_to_vehicle): one ray per pixel.
SceneRender render_street_scene(const Camera& camera, const Pose& camera_to_vehicle);

}  // namespace fishcam
