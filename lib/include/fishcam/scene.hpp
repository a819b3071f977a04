// A small deterministic street scene, ray-cast through any camera at any pose:
// the bundled default input, test data and ground truth for the augmentation.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string_view>

#include "fishcam/camera.hpp"
#include "fishcam/viewpoint.hpp"

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
  cv::Mat range;   // CV_32FC1, distance from the camera to the surface (m); +inf for the sky
};

// Renders the street scene. The scene lives in the vehicle frame of ISO 8855
// (x forward, y left, z up; metres; the road at z = 0); camera_to_vehicle places
// the camera (e.g. the WoodScape front camera's extrinsics). One ray per pixel
// centre, no anti-aliasing, so labels are exact. Pixels outside the camera's
// valid domain are black and background.
SceneRender render_street_scene(const Camera& camera, const Pose& camera_to_vehicle);

}  // namespace fishcam
