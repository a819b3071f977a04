// fishcam demo: the paper's Fig. 5 on the bundled scene and WoodScape front camera,
// plus samples of the small/medium/large presets, as contact sheets.
#include <opencv2/imgproc.hpp>

#include <cstdio>

#include "cli_common.hpp"
#include "commands.hpp"
#include "fishcam/augment/scene.hpp"
#include "fishcam/io/camera_io.hpp"

namespace fishcam::cli {
namespace {

constexpr double kThumbnail = 0.25;

// One cell: image and labels side by side at thumbnail size, a caption above.
cv::Mat cell(const cv::Mat& image, const cv::Mat& labels, const std::string& caption) {
  cv::Mat small_image, small_labels;
  cv::resize(image, small_image, {}, kThumbnail, kThumbnail, cv::INTER_AREA);
  cv::resize(colourise_labels(labels), small_labels, {}, kThumbnail, kThumbnail, cv::INTER_NEAREST);
  cv::Mat pair;
  cv::hconcat(small_image, small_labels, pair);
  cv::Mat out(pair.rows + 26, pair.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  pair.copyTo(out(cv::Rect(0, 26, pair.cols, pair.rows)));
  cv::putText(out, caption, {6, 18}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  return out;
}

cv::Mat grid(const std::vector<cv::Mat>& cells, int columns, const std::string& title) {
  const int w = cells[0].cols + 8, h = cells[0].rows + 8;
  const int rows = int((cells.size() + columns - 1) / columns);
  cv::Mat sheet(rows * h + 40, columns * w + 8, CV_8UC3, cv::Scalar(235, 235, 235));
  cv::putText(sheet, title, {10, 28}, cv::FONT_HERSHEY_SIMPLEX, 0.8, cv::Scalar(0, 0, 0), 2, cv::LINE_AA);
  for (size_t i = 0; i < cells.size(); ++i) {
    cells[i].copyTo(sheet(cv::Rect(8 + int(i % columns) * w, 40 + int(i / columns) * h, cells[i].cols, cells[i].rows)));
  }
  return sheet;
}

}  // namespace

void register_demo(CLI::App& app) {
  auto* cmd = app.add_subcommand("demo",
                                 "Render the bundled scene with the WoodScape front camera, augment it as in "
                                 "the paper's Fig. 5 and with the small/medium/large presets, write contact "
                                 "sheets");
  struct Options {
    std::string out = "fishcam-demo";
    bool force = false;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("--out", o->out, "Output folder (created)")->capture_default_str();
  cmd->add_flag("--force", o->force, "Replace the demo-*.png files already in --out");
  cmd->callback([o] {
    if (o->out.empty()) throw Error("--out: expected a folder, got ''");
    const std::filesystem::path dir = o->out;
    const std::filesystem::path camera_path = bundled_data("woodscape_front.json");
    check_output_not_input(dir, {camera_path}, true);
    const auto fig5 = dir / "demo-fig5.png", presets = dir / "demo-presets.png", render = dir / "demo-render.png",
               render_labels = dir / "demo-render-labels.png";
    // Before anything is computed: none of them replaces a file unless --force.
    std::filesystem::create_directories(dir);
    check_outputs({{fig5}, {presets}, {render}, {render_labels, true}}, {camera_path.string()}, o->force);
    const Camera camera = read_camera(camera_path);
    const SceneRender scene = render_street_scene(camera, *camera.parameters().pose);
    const ViewpointWarp warp(camera);
    WarpMaps maps;
    cv::Mat image, labels;
    auto augment = [&](const RigidMotion& change) {
      warp.compute(change, DepthPrior::source_sphere, &maps);
      warp_image(scene.image, maps, &image);
      warp_labels(scene.labels, maps, 0, &labels);
    };

    // Fig. 5: (a)-(c) rotation +-20 deg about x, y, z; (d)-(f) translation +-0.3 along x, y, z.
    std::vector<cv::Mat> cells{cell(scene.image, scene.labels, "original")};
    cells.push_back(cell(scene.image, scene.labels, "original"));
    const char* axes = "xyz";
    for (int kind = 0; kind < 2; ++kind) {
      for (int axis = 0; axis < 3; ++axis) {
        for (double sign : {+1.0, -1.0}) {
          Eigen::Vector3d r = Eigen::Vector3d::Zero(), t = Eigen::Vector3d::Zero();
          (kind == 0 ? r : t)[axis] = sign * (kind == 0 ? 20 : 0.3);
          augment(RigidMotion::from_euler_deg(r, t));
          char caption[64];
          std::snprintf(caption, sizeof caption, kind == 0 ? "rotate %+.0f deg about %c" : "translate %+.1f along %c",
                        kind == 0 ? r[axis] : t[axis], axes[axis]);
          cells.push_back(cell(image, labels, caption));
        }
      }
    }
    write_image(fig5, grid(cells, 2, "fishcam viewpoint augmentation (paper Fig. 5), source-sphere prior"), o->force);

    cells.clear();
    for (const char* name : {"small", "medium", "large"}) {
      for (std::uint64_t seed = 1; seed <= 3; ++seed) {
        const ViewpointChange pose = random_change(*find_pose_preset(name), seed);
        augment(pose.motion());
        char caption[96];
        std::snprintf(caption, sizeof caption, "%s #%llu r(%.0f,%.0f,%.0f) t(%.2f,%.2f,%.2f)", name,
                      static_cast<unsigned long long>(seed), pose.rotation_deg.x(), pose.rotation_deg.y(),
                      pose.rotation_deg.z(), pose.translation.x(), pose.translation.y(), pose.translation.z());
        cells.push_back(cell(image, labels, caption));
      }
    }
    write_image(presets, grid(cells, 3, "random poses: small (10 deg, 0.1), medium (20, 0.3), large (30, 0.5)"),
                o->force);
    write_images({{render, scene.image}, {render_labels, scene.labels}}, o->force);
    std::printf("camera %s\nwrote %s\nwrote %s\nwrote %s and %s (the rendered scene and its WoodScape labels)\n",
                camera_path.c_str(), fig5.c_str(), presets.c_str(), render.c_str(), render_labels.c_str());
  });
}

}  // namespace fishcam::cli
