// Camera file formats: the 28 real third-party files of ../shared/data/external
// read (against the published formulas, with the numbers copied from the files by
// hand) or refused naming why; write -> read round trips for every format and
// every registry model it can hold; camera selection and image sizes.
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>

#include <functional>
#include <nlohmann/json.hpp>
#include <set>

#include "fishcam/fit/fit.hpp"
#include "fishcam/testing/reference_models.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

using test::Intrinsics;

std::filesystem::path external(const std::string& name) { return test::shared_path("data/external") / name; }

using Reference = std::function<Eigen::Vector2d(const Eigen::Vector3d&)>;

// The camera against the reference over random rays up to max_theta (and the
// camera's domain), at distances 0.3 to 50: the worst pixel difference.
double worst_difference(const Camera& camera, const Reference& reference, double max_theta) {
  const double limit =
      std::min(max_theta, camera.domain().closed ? camera.domain().theta_max : camera.domain().theta_max - 1e-3);
  double worst = 0;
  int n = 0;
  for (const Eigen::Vector3d& ray : test::random_rays(5000, limit, 17)) {
    const Eigen::Vector3d p = ray * (0.3 + 49.7 * (n++ % 31) / 30.0);
    Eigen::Vector2d pixel;
    EXPECT_TRUE(camera.project(p, &pixel));
    worst = std::max(worst, (pixel - reference(p)).norm());
  }
  return worst;
}

// cv::fisheye::projectPoints (OpenCV's own code) for rays below 90 deg.
double worst_against_opencv(const Camera& camera, const Intrinsics& k, const std::array<double, 4>& d) {
  std::vector<cv::Point3d> points;
  const double limit = std::min(89 * M_PI / 180, camera.domain().theta_max);  // some lenses fold before 90 deg
  for (const Eigen::Vector3d& ray : test::random_rays(3000, limit, 23)) points.emplace_back(ray.x(), ray.y(), ray.z());
  std::vector<cv::Point2d> pixels;
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  cv::fisheye::projectPoints(points, pixels, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K,
                             cv::Vec4d(d[0], d[1], d[2], d[3]));
  double worst = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d pixel;
    if (!camera.project(Eigen::Vector3d(points[i].x, points[i].y, points[i].z), &pixel)) {
      ADD_FAILURE() << "a ray at " << std::acos(points[i].z) << " rad does not project";
      continue;
    }
    worst = std::max(worst, (pixel - Eigen::Vector2d(pixels[i].x, pixels[i].y)).norm());
  }
  return worst;
}

// ocamcalib_calib_results.txt's numbers.
const test::OCamCalib kOCamCalibFile{
    {-7.463674e+02, 0.000000e+00, 8.872435e-04, -1.024379e-06, 9.406640e-10},
    {976.011496, 423.799439, -71.005688, 109.822387, 14.864652, -10.577479, -103.634310, -135.380427, 365.628459,
     832.263016, 646.459114, 228.199663, 31.134605},
    630.102940,
    958.314910,
    0.996974,
    -0.014257,
    0.013102};

struct Readable {
  std::string file;
  std::string camera;  // empty: the default (first)
  std::string format, model;
  int width, height;
  Reference reference;
  double max_theta;
  // Kannala-Brandt files are also checked against OpenCV below 90 deg.
  std::optional<std::pair<Intrinsics, std::array<double, 4>>> opencv;
};

// cv::projectPoints (OpenCV's pinhole with its radial-tangential distortion, OpenCV's code).
Reference opencv_radtan(const Intrinsics& k, const std::vector<double>& d) {
  return [=](const Eigen::Vector3d& p) {
    const std::vector<cv::Point3d> points{{p.x(), p.y(), p.z()}};
    std::vector<cv::Point2d> pixels;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                      cv::Matx33d(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1), d, pixels);
    return Eigen::Vector2d(pixels[0].x, pixels[0].y);
  };
}

// cv::omnidir::projectPoints (opencv_contrib's Mei model, OpenCV's code).
Reference opencv_omnidir(const Intrinsics& k, double xi, const std::array<double, 4>& d) {
  return [=](const Eigen::Vector3d& p) {
    const std::vector<cv::Point3d> points{{p.x(), p.y(), p.z()}};
    std::vector<cv::Point2d> pixels;
    cv::omnidir::projectPoints(points, pixels, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                               cv::Matx33d(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1), xi,
                               cv::Vec4d(d[0], d[1], d[2], d[3]));
    return Eigen::Vector2d(pixels[0].x, pixels[0].y);
  };
}

std::vector<Readable> readable_files() {
  const double kFull = M_PI;
  auto kb = [](Intrinsics k, std::array<double, 4> d) {
    return [=](const Eigen::Vector3d& p) { return test::kannala_brandt(k, d, p); };
  };
  const Intrinsics tumvi{190.97847715128717, 190.9733070521226, 254.93170605935475, 256.8974428996504};
  const std::array<double, 4> tumvi_d{0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202,
                                      0.00020293673591811182};
  const Intrinsics t265_cam1{281.49219856329046, 280.3289056204996, 414.09933409091184, 406.02198481912353};
  const std::array<double, 4> t265_cam1_d{-0.0028480208540388407, 0.05429895807264252, -0.0516469474707301,
                                          0.010954064142332987};
  const Intrinsics basalt_kb{286.60144163375528, 286.4617087423328, 422.2765876951761, 395.2246466040553};
  const std::array<double, 4> basalt_kb_d{-0.006762412326815424, 0.045170283325720008, -0.043515167278210638,
                                          0.008374959821591333};
  const Intrinsics camodocal{286.2373962402344, 286.4901123046875, 421.489990234375, 400.760986328125};
  const std::array<double, 4> camodocal_d{-0.00703547615557909, 0.042284730821847916, -0.03999178111553192,
                                          0.006651225965470076};
  const Intrinsics orb2{285.284, 285.469, 423.582, 412.376};
  const std::array<double, 4> orb2_d{-0.0011336730094626546, 0.02848909981548786, -0.02476550079882145,
                                     0.0018412149511277676};
  const Intrinsics panyu{991, 991, 1612, 1617};
  const Intrinsics panyu_colmap{991, 991, 1612 - 0.5, 1617 - 0.5};  // COLMAP's pixel centres at +0.5
  const std::array<double, 4> panyu_d{0.024943212941115993, 0.0049984956352712093, -0.017541641442409061,
                                      0.0045520708951808514};
  const Intrinsics modalai{4.6089521210754816e+02, 4.6131778898262439e+02, 6.7449558584818692e+02,
                           3.9842248409866886e+02};
  const std::array<double, 4> modalai_d{5.1711564126224734e-02, 2.6006282671421282e-02, -1.3105287746560544e-02,
                                        1.3645308211349091e-03};
  const Intrinsics ds{158.28600034966977, 158.2743455478755, 254.96116578191653, 256.8894394501779};
  const Intrinsics eucm{460.76484651566468, 459.4051018049483, 365.8937161309615, 249.33499869752445};
  return {
      {"openvins_tum_vi_kalibr_imucam_chain.yaml",
       "",
       "kalibr",
       "kannala-brandt",
       512,
       512,
       kb(tumvi, tumvi_d),
       kFull,
       {{tumvi, tumvi_d}}},
      {"openvins_rs_t265_kalibr_imucam_chain.yaml",
       "cam1",
       "kalibr",
       "kannala-brandt",
       848,
       800,
       kb(t265_cam1, t265_cam1_d),
       kFull,
       {{t265_cam1, t265_cam1_d}}},
      {"basalt_t265_kb4_calib.json",
       "",
       "basalt",
       "kannala-brandt",
       848,
       800,
       kb(basalt_kb, basalt_kb_d),
       kFull,
       {{basalt_kb, basalt_kb_d}}},
      {"vinsfusion_t265_left_KANNALA_BRANDT.yaml",
       "",
       "camodocal",
       "kannala-brandt",
       848,
       800,
       kb(camodocal, camodocal_d),
       kFull,
       {{camodocal, camodocal_d}}},
      {"orbslam3_fisheye_KannalaBrandt8.yaml",
       "Camera2",
       "orbslam3",
       "kannala-brandt",
       848,
       800,
       kb(orb2, orb2_d),
       kFull,
       {{orb2, orb2_d}}},
      {"panyu_ros_style_fisheye_camera_intrinsics.yaml",
       "",
       "ros",
       "kannala-brandt",
       3264,
       3264,
       kb(panyu, panyu_d),
       kFull,
       {{panyu, panyu_d}}},
      {"colmap_opencv_fisheye_cameras.txt",
       "2",
       "colmap",
       "kannala-brandt",
       3264,
       3264,
       kb(panyu_colmap, panyu_d),
       kFull,
       {{panyu_colmap, panyu_d}}},
      {"modalai_opencv_tracking_down_intrinsics.yml",
       "",
       "opencv",
       "kannala-brandt",
       1280,
       800,
       kb(modalai, modalai_d),
       kFull,
       {{modalai, modalai_d}}},
      {"basalt_tumvi_512_ds_calib.json",
       "",
       "basalt",
       "double-sphere",
       512,
       512,
       [=](const Eigen::Vector3d& p) { return test::double_sphere(ds, -0.17213086034353243, 0.5931177593944744, p); },
       kFull,
       {}},
      {"basalt_euroc_eucm_calib.json",
       "0",
       "basalt",
       "extended-unified",
       752,
       480,
       [=](const Eigen::Vector3d& p) { return test::eucm(eucm, 0.5903365915227143, 1.127468196965374, p); },
       kFull,
       {}},
      // Not radially symmetric: OpenCV's and Mei's tangential terms, against OpenCV's own code.
      {"mrcal_cam0.opencv8.cameramodel",
       "",
       "mrcal",
       "opencv",
       4000,
       2200,
       opencv_radtan({1761.181055, 1761.250444, 1965.706996, 1087.518797},
                     {-0.01266096516, 0.03590794372, -0.0002547045941, 0.0005275929652, 0.01968883397, 0.01482863541,
                      -0.0562239888, 0.0500223357}),
       kFull,
       {}},
      {"mrcal_figueroa_opencv8-0.cameramodel",
       "",
       "mrcal",
       "opencv",
       6016,
       4016,
       opencv_radtan({2073.872915, 2077.452267, 3004.686823, 1997.377253},
                     {0.4791613797, 0.0266824914, 4.398264387e-05, -1.180073913e-05, 8.959722542e-05, 0.7666912469,
                      0.09633561231, 0.001407513313}),
       kFull,
       {}},
      {"photonvision_camera-0.cameramodel",
       "",
       "mrcal",
       "opencv",
       1600,
       896,
       opencv_radtan({1190.608979, 1190.068998, 804.2783086, 455.1773601},
                     {0.02722490305, -0.1509815462, -0.0005247860649, 0.000941291852, 0.1112874619, -0.009490756014,
                      0.01096065265, -0.0004255420927}),
       65 * M_PI / 180,
       {}},  // valid to 79 deg, where pixels are 5e8 from the centre and 1e-9 px is not a double's precision
      {"openvins_euroc_mav_kalibr_imucam_chain.yaml",
       "cam0",
       "kalibr",
       "opencv",
       752,
       480,
       opencv_radtan({458.654, 457.296, 367.215, 248.375}, {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05}),
       80 * M_PI / 180,
       {}},  // valid to 90 deg (no fold), pixels at 1e20 there
      {"vinsfusion_t265_omni_radtan_camchain.yaml",
       "cam0",
       "kalibr",
       "mei",
       848,
       800,
       opencv_omnidir({840.3541786270555, 841.7395501100224, 426.05865129442844, 400.00487827975144}, 2.001096742981025,
                      {0.26251514138713067, -0.8542295909903589, 0.005012383463787277, 0.0003963320511238702}),
       kFull,
       {}},
      {"vinsfusion_t265_fisheye1_MEI.yaml",
       "",
       "camodocal",
       "mei",
       848,
       800,
       [](const Eigen::Vector3d& p) {
         return test::mei_radtan({840.35417863, 841.73955011, 426.05865129, 400.00487828}, 2.00109674298,
                                 {0.26251514, -0.85422959, 0.00501238, 0.00039633}, p);
       },
       kFull,
       {}},
      {"vinsfisheye_dsta_cam0_mei.yaml",
       "",
       "camodocal",
       "mei",
       1280,
       960,
       opencv_omnidir({840.7517267665538, 753.2509367205932, 640.3867187257891, 483.95547527295696}, 1.7668989774186101,
                      {-0.0982253999263517, 0.11694029405469884, -0.00011437603929821573, -0.00489509708490966}),
       kFull,
       {}},
      // BoofCV's omnidirectional_universal with t1 = t2 = 0: Mei's model (BoofCV's UniOmniStoP).
      {"mei_omnidir_universal_fisheye.yaml",
       "",
       "boofcv",
       "mei",
       3840,
       2160,
       [](const Eigen::Vector3d& p) {
         return test::mei({2151.6168117931597, 2161.652781357435, 1894.179700702442, 968.7551405752832},
                          2.2268230796296904, 0.3207260522384846, 1.311770851988966, p);
       },
       kFull,
       {}},
      // OCamCalib: pol's exact inverse in OCamCalib's frame (x rows, y columns, looking along -z).
      {"ocamcalib_calib_results.txt",
       "",
       "ocamcalib",
       "ocam",
       1920,
       1208,
       [](const Eigen::Vector3d& p) {
         const Eigen::Vector2d row_column = test::ocam_world2cam_exact(kOCamCalibFile, {p.y(), p.x(), -p.z()}, 5000);
         return Eigen::Vector2d(row_column.y(), row_column.x());
       },
       120 * M_PI / 180,
       {}},  // the image's corners see 115 deg
      {"synwoodscape_FV.json",
       "",
       "woodscape",
       "polynomial",
       1280,
       966,
       [](const Eigen::Vector3d& p) {
         return test::woodscape({341.725, -26.4448, 32.7864, 0.50499}, 1280, 966, 0.329055, -3.5506, 1.00021, p);
       },
       kFull,
       {}},
  };
}

TEST(Formats, RealThirdPartyFilesAgreeWithThePublishedFormulas) {
  if (!std::filesystem::exists(external("README.md"))) GTEST_SKIP() << "no ../shared checkout";
  for (const auto& r : readable_files()) {
    CameraReadOptions options;
    if (!r.camera.empty()) options.camera = r.camera;
    CameraFileInfo info;
    const Camera camera = read_camera(external(r.file), options, &info);
    EXPECT_EQ(to_string(info.format), r.format) << r.file;
    EXPECT_EQ(model_name(camera.model()), r.model) << r.file;
    EXPECT_EQ(camera.width(), r.width) << r.file;
    EXPECT_EQ(camera.height(), r.height) << r.file;
    // 1e-9 px up to the model's limit (KB: 180 deg, where the formula is still defined).
    EXPECT_LE(worst_difference(camera, r.reference, r.max_theta), 1e-9) << r.file;
    if (r.opencv) {
      EXPECT_LE(worst_against_opencv(camera, r.opencv->first, r.opencv->second), 1e-9) << r.file;
    }
  }
}

// Every file of the collection is accounted for: read by one of the checks above or
// below, or refused with a reason; a file added to it without a check fails here.
TEST(Formats, EveryExternalFileIsReadAgainstAReferenceOrRefused) {
  if (!std::filesystem::exists(external("README.md"))) GTEST_SKIP() << "no ../shared checkout";
  std::set<std::string> checked;
  for (const auto& r : readable_files()) checked.insert(r.file);
  checked.insert("mrcal_cam0.splined.cameramodel");  // against libmrcal: Mrcal.SplinedStereographicAgreesWithLibmrcal
  for (const char* refused : {"opencv_filestorage_cameraMatrix_distCoeffs_fisheye.yml"}) {
    checked.insert(refused);  // FilesFishcamCannotHoldAreRefusedNamingWhy
  }
  // WoodScape-layout JSON: the WoodScape formula with the numbers as the file has them.
  for (const char* file : {"woodscape_valeoai_front.json", "synwoodscape_FV.json", "synwoodscape_MVL.json",
                           "synwoodscape_MVR.json", "synwoodscape_RV.json"}) {
    const auto in = nlohmann::json::parse(test::read_file(external(file)))["intrinsic"];
    std::vector<double> k;
    for (const char* key : {"k1", "k2", "k3", "k4"}) k.push_back(in[key].get<double>());
    const Camera camera = read_camera(external(file));
    const Reference reference = [&](const Eigen::Vector3d& p) {
      return test::woodscape(k, in["width"].get<double>(), in["height"].get<double>(), in["cx_offset"].get<double>(),
                             in["cy_offset"].get<double>(), in["aspect_ratio"].get<double>(), p);
    };
    EXPECT_LE(worst_difference(camera, reference, M_PI), 1e-9) << file;
    checked.insert(file);
  }
  // mrcal's pinhole files: the pinhole formula (mrcal.project itself: test_mrcal).
  for (const char* file :
       {"mrcal_pinhole-narrow-yawed-left.cameramodel", "mrcal_pinhole-narrow-yawed-right.cameramodel"}) {
    const Camera camera = read_camera(external(file));
    const Reference pinhole = [](const Eigen::Vector3d& p) {
      return Eigen::Vector2d(2405.678127 * p.x() / p.z() + 1508.569804, 2453.362582 * p.y() / p.z() + 978.395964);
    };
    EXPECT_LE(worst_difference(camera, pinhole, 60 * M_PI / 180), 1e-9) << file;
    EXPECT_EQ(camera.width(), 3008);
    checked.insert(file);
  }
  for (const auto& entry : std::filesystem::directory_iterator(external(""))) {
    const std::string name = entry.path().filename().string();
    if (name != "README.md") {
      EXPECT_TRUE(checked.count(name)) << name << " is not checked by any test";
    }
  }
  EXPECT_EQ(checked.size(), 28u);
}

TEST(Formats, PosesAreReadInFishcamsConvention) {
  if (!std::filesystem::exists(external("README.md"))) GTEST_SKIP() << "no ../shared checkout";
  // Kalibr's T_cam_imu maps IMU points into the camera: fishcam's pose (camera ->
  // reference) is its inverse, so R_pose = R^T and t_pose = -R^T t.
  const Camera kalibr = read_camera(external("openvins_tum_vi_kalibr_imucam_chain.yaml"));
  ASSERT_TRUE(kalibr.parameters().pose.has_value());
  Eigen::Matrix3d r;
  r << -0.9995250378696743, 0.029615343885863205, -0.008522328211654736, 0.0075019185074052044, -0.03439736061393144,
      -0.9993800792498829, -0.02989013031643309, -0.998969345370175, 0.03415885127385616;
  const Eigen::Vector3d t(0.04727988224914392, -0.047443232143367084, -0.0681999605066297);
  const Pose& pose = *kalibr.parameters().pose;
  EXPECT_LT((pose.rotation.toRotationMatrix() - r.transpose()).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((pose.translation - (-r.transpose() * t)).norm(), 1e-6);
  // basalt's T_imu_cam is camera -> IMU already.
  const Camera basalt = read_camera(external("basalt_tumvi_512_ds_calib.json"));
  const Eigen::Quaterniond q(0.007639340823570553, -0.013392900690257393, -0.6945866755293793, 0.7192437840259219);
  EXPECT_LT(basalt.parameters().pose->rotation.angularDistance(q.normalized()), 1e-12);
  EXPECT_LT((basalt.parameters().pose->translation -
             Eigen::Vector3d(0.04548094812071685, -0.07145370002838907, -0.046315428444919249))
                .norm(),
            1e-15);
}

// OCamCalib's own functions on the real file: our unprojection is cam2world (pol)
// exactly; our projection is world2cam up to invpol's own error (invpol only
// approximates pol's inverse); written back, the file reads as the same camera.
TEST(Formats, OCamCalibFileIsCam2worldAndWorld2cam) {
  if (!std::filesystem::exists(external("README.md"))) GTEST_SKIP() << "no ../shared checkout";
  const Camera camera = read_camera(external("ocamcalib_calib_results.txt"));
  const test::OCamCalib& o = kOCamCalibFile;
  double worst_angle = 0, worst_invpol = 0, worst_round_trip = 0;
  int pixels = 0;
  for (int v = 0; v < camera.height(); v += 16) {
    for (int u = 0; u < camera.width(); u += 16) {
      const Eigen::Vector3d ocam = test::ocam_cam2world(o, v, u);  // (row, column)
      const Eigen::Vector3d expected = Eigen::Vector3d(ocam.y(), ocam.x(), -ocam.z()).normalized();
      Eigen::Vector3d ray;
      ASSERT_TRUE(camera.unproject({double(u), double(v)}, &ray)) << u << ", " << v;
      worst_angle = std::max(worst_angle, std::atan2(ray.cross(expected).norm(), ray.dot(expected)));
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.project(ray, &pixel));
      worst_round_trip = std::max(worst_round_trip, (pixel - Eigen::Vector2d(u, v)).norm());
      const Eigen::Vector2d row_column = test::ocam_world2cam(o, ocam);
      worst_invpol = std::max(worst_invpol, (pixel - Eigen::Vector2d(row_column.y(), row_column.x())).norm());
      ++pixels;
    }
  }
  EXPECT_EQ(pixels, 120 * 76);
  EXPECT_LE(worst_angle, 1e-13);
  EXPECT_LE(worst_round_trip, 1e-9);
  EXPECT_LE(worst_invpol, 0.1);   // the file's invpol against its pol: measured 0.02 px
  EXPECT_GT(worst_invpol, 1e-4);  // (so this is not comparing pol with itself)
  EXPECT_EQ(camera.skew().xy, 0.013102);
  EXPECT_NEAR(camera.skew().yx, -0.014257 / 0.996974, 1e-15);

  // Written and read back: the same camera, with an invpol fitted to 1e-3 px.
  const std::string written = format_camera(camera.parameters(), CameraFormat::ocamcalib);
  const Camera back(parse_camera(written, "back.txt"));
  EXPECT_EQ(model_params(back.model()), model_params(camera.model()));
  EXPECT_EQ(back.principal_point(), camera.principal_point());
  EXPECT_EQ(back.pixel_scale(), camera.pixel_scale());
  EXPECT_NEAR(back.skew().yx, camera.skew().yx, 1e-15);
  std::istringstream lines(written);
  test::OCamCalib w = o;
  w.invpol.clear();
  for (std::string line; std::getline(lines, line);) {
    if (line.find("inverse mapping") == std::string::npos) continue;
    std::getline(lines, line), std::getline(lines, line);
    std::istringstream numbers(line);
    int n = 0;
    numbers >> n;
    w.invpol.resize(size_t(n));
    for (double& x : w.invpol) numbers >> x;
  }
  ASSERT_FALSE(w.invpol.empty());
  double worst_fit = 0;
  for (int v = 0; v < camera.height(); v += 16) {
    for (int u = 0; u < camera.width(); u += 16) {
      const Eigen::Vector3d ocam = test::ocam_cam2world(w, v, u);
      const Eigen::Vector2d row_column = test::ocam_world2cam(w, ocam);
      worst_fit = std::max(worst_fit, (row_column - Eigen::Vector2d(v, u)).norm());
    }
  }
  EXPECT_LE(worst_fit, 2e-3);
}

TEST(Formats, OCamCalibFilesThatCannotBeRightAreRefused) {
  CameraParameters p = test::every_model()[0].second;
  p.model = OCam<double>({-340.0, 0, 1 / 1020.0, 0, 0});
  p.grid.skew = {0.01, -0.02};
  const std::string good = format_camera(p, CameraFormat::ocamcalib);
  const Camera camera(parse_camera(good, "good.txt"));
  EXPECT_EQ(camera.skew(), p.grid.skew);
  const auto replaced = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return at == std::string::npos ? text : text.replace(at, from.size(), to);
  };
  const std::string pol_line =
      good.substr(good.find("\n\n") + 2, good.find('\n', good.find("\n\n") + 2) - good.find("\n\n") - 2);
  const size_t invpol_at = good.find("\n\n", good.find("inverse mapping")) + 2;
  const std::string invpol_line = good.substr(invpol_at, good.find('\n', invpol_at) - invpol_at);
  const std::string invpol_first = invpol_line.substr(
      invpol_line.find(' ') + 1, invpol_line.find(' ', invpol_line.find(' ') + 1) - invpol_line.find(' ') - 1);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {replaced(", starting from 0 (C convention)", ""), "does not say where its rows and columns start"},
      {replaced(pol_line, "6 -340 0 0.001 0 0 1e-12"), "degree up to 4"},
      {replaced(pol_line, "5 340 0 0.001 0 0"), "a0 must be < 0"},
      {replaced(invpol_line, invpol_line.substr(0, invpol_line.find(' ')) + " 1" + invpol_first +
                                 invpol_line.substr(invpol_line.find(' ', invpol_line.find(' ') + 1))),
       "invpol: misses pol's inverse by"},
      {good.substr(0, good.find("#image size")), "expected 5 blocks"},
      {replaced("966 1280", "966"), "image size (height width): expected 2 numbers"},
      {replaced(pol_line, "3 -340 0"), "pol: expected its count"},
      {replaced(pol_line, "5 -340 0 x 0 0"), "data line 1"},
  };
  int refused = 0;
  for (const auto& [text, expected] : cases) {
    try {
      parse_camera(text, "bad.txt");
      ADD_FAILURE() << "read: " << text;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(expected), std::string::npos) << what;
      EXPECT_EQ(what.rfind("bad.txt: ", 0), 0u) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      ++refused;
    }
  }
  EXPECT_EQ(refused, int(cases.size()));
}

TEST(Formats, FilesFishcamCannotHoldAreRefusedNamingWhy) {
  if (!std::filesystem::exists(external("README.md"))) GTEST_SKIP() << "no ../shared checkout";
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"opencv_filestorage_cameraMatrix_distCoeffs_fisheye.yml",
       "distortion_model: missing: 4 distortion coefficients could be"},
  };
  for (const auto& [file, expected] : refused) {
    try {
      read_camera(external(file));
      ADD_FAILURE() << file << " was read";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(expected), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      EXPECT_EQ(what.rfind(external(file).string(), 0), 0u) << what;  // names the file first
    }
  }
  // Told it is a fisheye file (by the caller, or by the file) and given the size,
  // the last one reads.
  const std::string text = test::read_file(external("opencv_filestorage_cameraMatrix_distCoeffs_fisheye.yml"));
  CameraReadOptions options;
  options.image_size = std::pair{1920, 1080};
  options.distortion_model = "fisheye";
  const CameraParameters p = parse_camera(text, "fisheye.yml", options);
  EXPECT_EQ(model_name(p.model), "kannala-brandt");
  EXPECT_EQ(model_params(p.model)[0], 3.5858622506170752e+02);
  options.distortion_model.reset();
  EXPECT_EQ(model_params(parse_camera(text + "distortion_model: fisheye\n", "f.yml", options).model)[1],
            -6.0217213307700412e-02);
  options.distortion_model = "plumb_bob";  // the caller contradicts the file
  EXPECT_THROW(parse_camera(text + "distortion_model: fisheye\n", "f.yml", options), Error);
  options.distortion_model = "fisheye";
  options.image_size.reset();
  EXPECT_THROW(parse_camera(text, "fisheye.yml", options), Error);  // no size: refused, not guessed
}

// Every format (one test per format, from the library's list) with every registry
// model: the models of its list are written, read back and project the same (to
// 1e-9 px over the valid domain); the others are refused in one line naming the
// model. Which models a format holds comes from the list, so a writer that starts
// refusing one of them, or takes one it should not, fails here.
class EveryFormat : public ::testing::TestWithParam<CameraFormat> {};

TEST_P(EveryFormat, RoundTripsTheModelsOfItsListAndRefusesTheOthers) {
  const CameraFormat format = GetParam();
  const std::vector<std::string> holds = camera_format_models(format);
  ASSERT_FALSE(holds.empty());
  int held = 0, refused = 0, tangential_held = 0;
  for (auto [label, p] : test::every_camera()) {
    p.pose = Pose{Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())), {0.1, -0.2, 1.5}};
    const bool model_listed = std::find(holds.begin(), holds.end(), model_name(p.model)) != holds.end();
    const bool listed = model_listed && camera_format_holds(format, p.distortion);
    std::string text;
    try {
      text = format_camera(p, format);
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_FALSE(listed) << label << ": a camera the format holds refused: " << what;
      if (!model_listed) {
        EXPECT_NE(what.find("format holds"), std::string::npos) << what;
        EXPECT_NE(what.find(std::string("not ") + std::string(model_name(p.model))), std::string::npos) << what;
      } else {
        const std::string part(distortion_name(p.distortion));
        EXPECT_EQ(what.rfind(part + ": the " + std::string(to_string(format)) + " format cannot hold ", 0), 0u) << what;
      }
      ++refused;
      continue;
    }
    tangential_held += p.tangential_terms().any();
    EXPECT_TRUE(listed) << label << ": written, but not in the format's list";
    ++held;
    CameraReadOptions options;
    options.format = format;
    options.image_size = std::pair{p.width, p.height};
    const Camera back(parse_camera(text, label, options));
    const Camera original(p);
    EXPECT_TRUE(same_distortion(back.parameters().distortion, p.distortion)) << label;
    EXPECT_EQ(back.width(), p.width);
    EXPECT_EQ(back.height(), p.height);
    const double limit = original.domain().closed ? original.domain().theta_max : original.domain().theta_max - 1e-3;
    double worst = 0;
    for (const Eigen::Vector3d& ray : test::random_rays(2000, limit, 3)) {
      Eigen::Vector2d a, b;
      ASSERT_TRUE(original.project(ray, &a));
      ASSERT_TRUE(back.project(ray, &b)) << label;
      worst = std::max(worst, (a - b).norm() / (1 + 1e-3 * (a - original.principal_point()).norm()));
    }
    EXPECT_LE(worst, 1e-9) << label;
    if (back.parameters().pose) {  // formats with poses keep them
      EXPECT_LT(back.parameters().pose->rotation.angularDistance(p.pose->rotation), 1e-12);
      EXPECT_LT((back.parameters().pose->translation - p.pose->translation).norm(), 1e-12);
    }
    if (model_name(back.model()) == model_name(original.model()) && p.grid.pixel_scale.x() == 1 &&
        (format == CameraFormat::fishcam || format == CameraFormat::kalibr || format == CameraFormat::basalt)) {
      // Stored as they are (basalt's unified model: the alpha form, exact to rounding).
      const auto a = model_params(original.model()), b = model_params(back.model());
      for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 4e-16 * std::abs(a[i])) << label;
    }
  }
  EXPECT_EQ(held + refused, int(test::every_camera().size()));
  EXPECT_GT(held, 0);
  // Every format that holds p1, p2 holds at least one model with an undistorted plane.
  EXPECT_EQ(tangential_held > 0, camera_format_holds(format, TangentialDistortion{{0.001, 0, {}}}))
      << to_string(format);
}

// A user limit on the valid domain, one angle or one per azimuth sector: fishcam JSON
// only (to 1e-15 rad: stored in degrees); every other format refuses it by name.
TEST_P(EveryFormat, HoldsAThetaLimitOnlyIfFishcam) {
  CameraParameters p = test::woodscape_front();
  p.model = Equidistant<double>(340);
  p.theta_limit = 1.2;
  CameraParameters by_azimuth = p;
  AzimuthSectors& limits = by_azimuth.theta_limit_by_azimuth.emplace();
  for (size_t k = 0; k < limits.size(); ++k) limits[k] = 0.4 + 0.03 * double(k);
  const std::string name(to_string(GetParam()));
  int cases = 0;
  for (const auto& [camera, refusal] :
       {std::pair{p, "theta_limit: the " + name + " format cannot store a user field-of-view limit"},
        std::pair{by_azimuth,
                  "theta_limit_by_azimuth: the " + name + " format cannot store a per-azimuth field-of-view limit"}}) {
    ++cases;
    if (GetParam() == CameraFormat::fishcam) {
      const CameraParameters back = parse_camera(format_camera(camera, GetParam()), "x", GetParam());
      EXPECT_EQ(*back.theta_limit, 1.2);
      ASSERT_EQ(back.theta_limit_by_azimuth.has_value(), camera.theta_limit_by_azimuth.has_value());
      for (size_t k = 0; camera.theta_limit_by_azimuth && k < limits.size(); ++k) {
        EXPECT_NEAR((*back.theta_limit_by_azimuth)[k], limits[k], 1e-15);
      }
      continue;
    }
    try {
      format_camera(camera, GetParam());
      ADD_FAILURE() << "a theta limit was written";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).find(refusal), 0u) << e.what();
    }
  }
  EXPECT_EQ(cases, 2);
}

// A skewed pixel grid: written and read back by the formats that hold one (the
// projection within 1e-9 px), refused naming the skew by the others; each format
// gets the registry example of a model it lists.
TEST_P(EveryFormat, HoldsASkewedGridOrSaysItCannot) {
  const CameraFormat format = GetParam();
  const std::vector<std::string> holds = camera_format_models(format);
  int tried = 0;
  for (auto [label, p] : test::every_model()) {
    if (std::find(holds.begin(), holds.end(), model_name(p.model)) == holds.end()) continue;
    p.grid.skew = {0.0131, 0};  // BoofCV's skew is xy alone
    ++tried;
    std::string text;
    try {
      text = format_camera(p, format);
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("skew: the " + std::string(to_string(format)) + " format cannot hold", 0),
                0u)
          << e.what();
      break;
    }
    CameraReadOptions options;
    options.format = format;
    const Camera back(parse_camera(text, label, options)), original(p);
    EXPECT_NEAR(back.skew().xy, p.grid.skew.xy, 1e-15) << label;
    double worst = 0;
    for (const Eigen::Vector3d& ray : test::random_rays(500, std::min(1.5, original.domain().theta_max - 1e-3), 5)) {
      Eigen::Vector2d a, b;
      ASSERT_TRUE(original.project(ray, &a));
      ASSERT_TRUE(back.project(ray, &b)) << label;
      worst = std::max(worst, (a - b).norm());
    }
    EXPECT_LE(worst, 1e-9) << label;
    break;
  }
  EXPECT_EQ(tried, 1);
}

INSTANTIATE_TEST_SUITE_P(Formats, EveryFormat, ::testing::ValuesIn(camera_formats()),
                         [](const ::testing::TestParamInfo<CameraFormat>& info) {
                           return std::string(to_string(info.param));
                         });

// docs/formats.md's table lists, per format, exactly the models of its list.
TEST(Formats, TheDocsTableListsEachFormatsModels) {
  const std::string docs = test::read_file(test::data_path("..") / "docs" / "formats.md");
  int rows = 0;
  for (const CameraFormat format : camera_formats()) {
    const std::string key = "| `" + std::string(to_string(format)) + "` |";
    const size_t at = docs.find(key);
    ASSERT_NE(at, std::string::npos) << key;
    const std::string row = docs.substr(at, docs.find('\n', at) - at);
    const std::string models = row.substr(row.rfind('|', row.size() - 2) + 2);
    std::string expected;
    const auto names = camera_format_models(format);
    for (size_t i = 0; i < names.size(); ++i) expected += (i ? ", " : "") + names[i];
    if (format == CameraFormat::fishcam) expected = "every model";
    EXPECT_EQ(models.substr(0, models.size() - 2), expected) << row;
    ++rows;
  }
  EXPECT_EQ(rows, int(camera_formats().size()));
}

TEST(Formats, CamerasAreChosenByNameOrIndexAndSizesChecked) {
  CameraParameters p = test::woodscape_front();
  p.model = KannalaBrandt<double>(331.5526, 0.0346514, 0.0241055, -0.0074981, 0.0007767);
  std::string chain = format_camera(p, CameraFormat::kalibr);
  CameraParameters other = p;
  other.model = KannalaBrandt<double>(300, 0.0346514, 0.0241055, -0.0074981, 0.0007767);
  std::string second = format_camera(other, CameraFormat::kalibr);
  second.replace(0, 5, "cam1:");
  const std::string both = chain + second;
  CameraFileInfo info;
  CameraReadOptions options;
  EXPECT_EQ(model_params(parse_camera(both, "chain.yaml", options, &info).model)[0], 331.5526);
  EXPECT_EQ(info.camera_count, 2);
  EXPECT_EQ(info.camera_name, "cam0");
  ASSERT_FALSE(info.notes.empty());  // the default is said
  for (const char* which : {"cam1", "1"}) {
    options.camera = which;
    EXPECT_EQ(model_params(parse_camera(both, "chain.yaml", options, &info).model)[0], 300.0) << which;
    EXPECT_EQ(info.camera_index, 1);
  }
  options.camera = "cam7";
  try {
    parse_camera(both, "chain.yaml", options);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no camera 'cam7' (the file has 0 = 'cam0', 1 = 'cam1')"), std::string::npos)
        << e.what();
  }
  options.camera.reset();
  options.image_size = std::pair{640, 480};
  EXPECT_THROW(parse_camera(both, "chain.yaml", options), Error);  // the file says 1280x966
  // A file without a size: refused without one, read with one.
  std::string orb = format_camera(p, CameraFormat::orbslam3);
  orb = orb.substr(0, orb.find("\nCamera.width"));
  try {
    parse_camera(orb, "orb.yaml");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("image_size: the ORB-SLAM3 settings YAML file has no image size"),
              std::string::npos)
        << e.what();
  }
  options.image_size = std::pair{1280, 966};
  EXPECT_EQ(parse_camera(orb, "orb.yaml", options).width, 1280);
}

// fishcam convert's report against the target's own formula: the WoodScape front
// camera converted to each model, written in a format that holds it, read back,
// and its pixel error over the same samples computed with the published formula.
TEST(Formats, ConversionReportsAgreeWithTheTargetsOwnFormula) {
  const Camera source = read_camera(test::data_path("woodscape_front.json"));
  const auto samples = sample_image(source, 2, 0);
  struct Target {
    const char* model;
    CameraFormat format;
    std::function<Eigen::Vector2d(const Intrinsics&, const std::vector<double>&, const Eigen::Vector3d&)> formula;
  };
  const std::vector<Target> targets = {
      {"double-sphere", CameraFormat::basalt,
       [](auto& k, auto& q, auto& p) { return test::double_sphere(k, q[1], q[2], p); }},
      {"extended-unified", CameraFormat::kalibr,
       [](auto& k, auto& q, auto& p) { return test::eucm(k, q[1], q[2], p); }},
      {"unified", CameraFormat::basalt, [](auto& k, auto& q, auto& p) { return test::ucm_xi(k, q[1], p); }},
      {"mei", CameraFormat::camodocal, [](auto& k, auto& q, auto& p) { return test::mei(k, q[1], q[2], q[3], p); }},
      {"kannala-brandt", CameraFormat::ros,
       [](auto& k, auto& q, auto& p) {
         return test::kannala_brandt(k, {q[1], q[2], q[3], q[4]}, p);
       }},
  };
  for (const auto& t : targets) {
    const Conversion conversion = convert_camera(source, parse_model_spec(t.model));
    const Camera back(parse_camera(format_camera(conversion.camera, t.format), t.model, t.format));
    const auto q = model_params(back.model());
    const Intrinsics k{q[0] * back.pixel_scale().x(), q[0] * back.pixel_scale().y(), back.principal_point().x(),
                       back.principal_point().y()};
    double sum2 = 0;
    long n = 0;
    for (const auto& s : samples) {
      Eigen::Vector2d unused;
      if (!back.project(s.ray, &unused)) continue;  // outside the target's domain: reported as unprojectable
      sum2 += (t.formula(k, q, s.ray) - s.pixel).squaredNorm(), ++n;
    }
    EXPECT_EQ(n, conversion.report.samples) << t.model;
    EXPECT_NEAR(std::sqrt(sum2 / double(n)), conversion.report.rms_px, 1e-6) << t.model;
    std::printf("  %-17s rms %.4f px, max %.4f px (%s)\n", t.model, conversion.report.rms_px, conversion.report.max_px,
                std::string(to_string(t.format)).c_str());
  }
}

// COLMAP's pinhole distortion models are OpenCV's: x = X/Z, r^2 = x^2 + y^2,
// u = fx x (1 + k1 r^2 + k2 r^4) + cx - 0.5 (COLMAP's pixel centres at 0.5), read as `opencv`;
// OPENCV's p1, p2 as cv::projectPoints has them.
TEST(Formats, ColmapRadialModelsAreOpenCVs) {
  const Camera radial(parse_camera("1 RADIAL 640 480 500 320 240 -0.2 0.05\n", "cameras.txt"));
  const Camera full(
      parse_camera("1 FULL_OPENCV 640 480 500 505 320 240 -0.2 0.05 0 0 0.01 0.02 -0.01 0.003\n", "cameras.txt"));
  int checked = 0;
  for (const auto& ray : test::random_rays(2000, 40 * M_PI / 180, 3)) {
    const double x = ray.x() / ray.z(), y = ray.y() / ray.z(), r2 = x * x + y * y;
    Eigen::Vector2d q;
    ASSERT_TRUE(radial.project(ray, &q));
    const double d = 1 + r2 * (-0.2 + r2 * 0.05);
    EXPECT_LT((q - Eigen::Vector2d(500 * x * d + 319.5, 500 * y * d + 239.5)).norm(), 1e-9);
    ASSERT_TRUE(full.project(ray, &q));
    const double e = (1 + r2 * (-0.2 + r2 * (0.05 + r2 * 0.01))) / (1 + r2 * (0.02 + r2 * (-0.01 + r2 * 0.003)));
    EXPECT_LT((q - Eigen::Vector2d(500 * x * e + 319.5, 505 * y * e + 239.5)).norm(), 1e-9);
    ++checked;
  }
  EXPECT_EQ(checked, 2000);
  EXPECT_EQ(model_name(radial.model()), "opencv");
  // OPENCV's p1, p2 are OpenCV's tangential terms.
  const Camera tangential(parse_camera("1 OPENCV 640 480 500 505 320 240 -0.2 0.05 0.001 -0.002\n", "cameras.txt"));
  const Reference reference = opencv_radtan({500, 505, 319.5, 239.5}, {-0.2, 0.05, 0.001, -0.002});
  EXPECT_LE(worst_difference(tangential, reference, 40 * M_PI / 180), 1e-9);
  EXPECT_EQ(tangential.parameters().tangential_terms(), (TangentialTerms{0.001, -0.002, {}}));
}

TEST(Formats, DetectionScoresTheFormatsOwnKeys) {
  const CameraParameters p = test::every_model()[5].second;  // kannala-brandt
  for (CameraFormat f : {CameraFormat::opencv, CameraFormat::kalibr, CameraFormat::basalt, CameraFormat::colmap,
                         CameraFormat::ros, CameraFormat::camodocal, CameraFormat::orbslam3, CameraFormat::fishcam}) {
    EXPECT_EQ(detect_camera_format(format_camera(p, f), "x"), f) << to_string(f);
  }
}

}  // namespace
}  // namespace fishcam
