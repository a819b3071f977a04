// Camera files: every format round-trips, mrcal's Python module reads what we
// write, and malformed input gives a one-line error naming file and field.
#include <opencv2/core.hpp>

#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

using test::data_path;

void expect_same_camera(const CameraParameters& a, const CameraParameters& b, double tolerance = 0) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(model_name(a.model), model_name(b.model));
  const auto pa = model_params(a.model), pb = model_params(b.model);
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i) EXPECT_NEAR(pa[i], pb[i], tolerance * std::abs(pa[i])) << i;
  EXPECT_NEAR((a.grid.principal_point - b.grid.principal_point).norm(), 0.0, tolerance * 1000);
  EXPECT_NEAR((a.grid.pixel_scale - b.grid.pixel_scale).norm(), 0.0, tolerance);
  ASSERT_EQ(a.pose.has_value(), b.pose.has_value());
  if (a.pose) {
    // Formats that store a Rodrigues vector (mrcal) convert through it: a few ulps.
    EXPECT_LT(a.pose->rotation.angularDistance(b.pose->rotation), 4e-16 * 4 + tolerance);
    EXPECT_LT((a.pose->translation - b.pose->translation).norm(),
              4e-16 * (1 + a.pose->translation.norm()) + tolerance * 10);
  }
}

// Every bundled camera file and its format.
const std::pair<const char*, CameraFormat> kBundled[] = {{"woodscape_front.json", CameraFormat::woodscape},
                                                         {"stereographic.cameramodel", CameraFormat::mrcal},
                                                         {"pinhole.cameramodel", CameraFormat::mrcal},
                                                         {"kannala_brandt.yaml", CameraFormat::opencv},
                                                         {"equidistant.json", CameraFormat::fishcam}};

TEST(CameraIo, BundledFilesAreDetectedByContent) {
  for (const auto& [name, format] : kBundled) {
    CameraFormat detected{};
    read_camera(data_path(name), &detected);
    EXPECT_EQ(detected, format) << name;
  }
}

TEST(CameraIo, EveryFormatRoundTrips) {
  for (const auto& [name, format] : kBundled) {
    const CameraParameters original = read_camera(data_path(name)).parameters();
    // Own format: WoodScape stores offsets from the image centre (cx - W/2 + 0.5), a
    // rounding step away from exact; the others store the numbers themselves.
    const double tolerance = format == CameraFormat::woodscape ? 1e-15 : 0;
    expect_same_camera(original, parse_camera(format_camera(original, format), "again"), tolerance);
    // fishcam JSON holds every camera exactly.
    expect_same_camera(original, parse_camera(format_camera(original, CameraFormat::fishcam), "fishcam"));
  }
}

TEST(CameraIo, PoseAndAspectSurviveEveryFormat) {
  CameraParameters p = test::woodscape_front();
  p.pose = Pose{Eigen::Quaterniond(Eigen::AngleAxisd(2.5, Eigen::Vector3d(-1, 2, 0.5).normalized())),
                Eigen::Vector3d(3.7, -0.2, 0.66)};
  p.grid.pixel_scale = {1.01, 1.03};  // a_x != 1: formats with one focal length rescale the model
  const std::pair<RadialModel, CameraFormat> cases[] = {
      {Polynomial<double>({339.749, -31.988, 48.275, -7.201}), CameraFormat::woodscape},
      {Stereographic<double>(330), CameraFormat::mrcal},
      {Pinhole<double>(600), CameraFormat::mrcal},
      {KannalaBrandt<double>(331, 0.03, 0.02, -0.007, 0.0007), CameraFormat::opencv},
      {Equidistant<double>(340), CameraFormat::fishcam},
  };
  for (const auto& [model, format] : cases) {
    p.model = model;
    const Camera original(p), back(parse_camera(format_camera(p, format), "again"));
    // Same camera: identical projections (the parameters may be rescaled).
    for (const auto& ray : test::random_rays(1000, 1.4, 2)) {
      Eigen::Vector2d a, b;
      ASSERT_TRUE(original.project(ray, &a) && back.project(ray, &b));
      EXPECT_LT((a - b).norm(), 1e-9) << to_string(format);
    }
    EXPECT_LT(original.parameters().pose->rotation.angularDistance(back.parameters().pose->rotation), 1e-14);
    EXPECT_LT((original.parameters().pose->translation - back.parameters().pose->translation).norm(), 1e-14);
  }
}

TEST(CameraIo, FormatsRefuseCamerasTheyCannotHold) {
  CameraParameters p = test::woodscape_front();
  auto expect_error = [&](CameraFormat format, const std::string& needle) {
    try {
      format_camera(p, format);
      FAIL() << "accepted: " << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error(CameraFormat::mrcal, "the mrcal format holds pinhole, stereographic and opencv");
  expect_error(CameraFormat::opencv, "kannala-brandt");
  p.model = Stereographic<double>(300);
  expect_error(CameraFormat::woodscape, "polynomial");
  p.model = Polynomial<double>({339.749, -31.988, 48.275, -7.201});
  p.theta_limit = 1.5;
  expect_error(CameraFormat::woodscape, "theta_limit");
  expect_error(CameraFormat::mrcal, "theta_limit");
  EXPECT_NO_THROW(format_camera(p, CameraFormat::fishcam));
}

TEST(CameraIo, WriteNeverOverwritesUnlessAsked) {
  const auto dir = test::scratch_dir("write");
  const auto path = test::write_file(dir / "mine.json", "precious");
  const CameraParameters p = test::woodscape_front();
  EXPECT_THROW(write_camera(p, path, CameraFormat::fishcam), Error);
  EXPECT_EQ(test::read_file(path), "precious");
  write_camera(p, path, CameraFormat::fishcam, /*overwrite=*/true);
  expect_same_camera(p, read_camera(path).parameters());
  EXPECT_THROW(write_camera(p, dir / "no/such/dir/cam.json", CameraFormat::fishcam), Error);
  // A camera the format cannot hold leaves no file behind.
  EXPECT_THROW(write_camera(p, dir / "cam.cameramodel", CameraFormat::mrcal), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "cam.cameramodel"));
}

TEST(CameraIo, MrcalPythonReadsWhatWeWriteAndWeReadWhatItWrites) {
  const auto dir = test::scratch_dir("mrcal_python");
  CameraParameters p = read_camera(data_path("stereographic.cameramodel")).parameters();
  p.pose = Pose{Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -1, 0.3).normalized())),
                Eigen::Vector3d(1.25, -0.5, 0.125)};
  write_camera(p, dir / "ours.cameramodel", CameraFormat::mrcal);
  // mrcal loads our file, projects a point, and writes the model back in its own style.
  const std::string script =
      "import mrcal, numpy as np\n"
      "m = mrcal.cameramodel('" +
      (dir / "ours.cameramodel").string() +
      "')\n"
      "print(m.intrinsics()[0], *['%.17g' % x for x in m.intrinsics()[1]])\n"
      "print(*['%.17g' % x for x in mrcal.project(np.array([0.3, -0.2, -0.4]), *m.intrinsics())])\n"
      "m.write('" +
      (dir / "theirs.cameramodel").string() + "')\n";
  test::write_file(dir / "check.py", script);
  const std::string command =
      "/usr/bin/python3 '" + (dir / "check.py").string() + "' > '" + (dir / "out.txt").string() + "' 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << test::read_file(dir / "out.txt");
  std::istringstream out(test::read_file(dir / "out.txt"));
  std::string lensmodel;
  double fx, fy, cx, cy, u, v;
  out >> lensmodel >> fx >> fy >> cx >> cy >> u >> v;
  EXPECT_EQ(lensmodel, "LENSMODEL_STEREOGRAPHIC");
  EXPECT_EQ(fx, 330.0);
  EXPECT_EQ(fy, 331.5);
  EXPECT_EQ(cx, p.grid.principal_point.x());
  Eigen::Vector2d pixel;
  ASSERT_TRUE(Camera(p).project({0.3, -0.2, -0.4}, &pixel));  // behind the camera
  EXPECT_NEAR(pixel.x(), u, 1e-9);
  EXPECT_NEAR(pixel.y(), v, 1e-9);
  // mrcal writes extrinsics with 10 significant digits.
  expect_same_camera(p, read_camera(dir / "theirs.cameramodel").parameters(), 1e-9);
}

// ---------------------------------------------------------------- malformed input
struct Malformed {
  const char* name;
  std::string content;
  const char* expected;  // a piece of the one-line error
};

const std::string kWoodScape = test::read_file(data_path("woodscape_front.json"));
const std::string kFishcam = test::read_file(data_path("equidistant.json"));
const std::string kMrcal = test::read_file(data_path("stereographic.cameramodel"));
const std::string kOpenCV = test::read_file(data_path("kannala_brandt.yaml"));

std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  return s.replace(pos, from.size(), to);
}

const Malformed kMalformed[] = {
    // WoodScape
    {"ws_missing_k1", replaced(kWoodScape, "\"k1\": 339.749,", ""), "intrinsic.k1: missing"},
    {"ws_k1_string", replaced(kWoodScape, "339.749", "\"339.749\""), "intrinsic.k1: expected a number, got string"},
    {"ws_k1_zero", replaced(kWoodScape, "339.749", "0"), "k1 must be > 0"},
    {"ws_k1_negative", replaced(kWoodScape, "339.749", "-339.749"), "k1 must be > 0"},
    {"ws_width_negative", replaced(kWoodScape, "\"width\": 1280", "\"width\": -1280"), "intrinsic.width"},
    {"ws_width_fraction", replaced(kWoodScape, "\"width\": 1280", "\"width\": 1280.5"), "intrinsic.width"},
    {"ws_nan", replaced(kWoodScape, "339.749", "NaN"), "not valid JSON"},
    {"ws_truncated", kWoodScape.substr(0, kWoodScape.size() / 2), "not valid JSON"},
    {"ws_no_order", replaced(kWoodScape, "\"poly_order\": 4,", ""), "intrinsic.poly_order: missing"},
    {"ws_order", replaced(kWoodScape, "\"poly_order\": 4,", "\"poly_order\": 5,"), "intrinsic.k5: missing"},
    {"ws_model", replaced(kWoodScape, "radial_poly", "fisheye_mei"), "intrinsic.model: unsupported WoodScape model"},
    {"ws_aspect", replaced(kWoodScape, "\"aspect_ratio\": 1.0", "\"aspect_ratio\": 0"), "intrinsic.aspect_ratio"},
    {"ws_quaternion", replaced(kWoodScape, "0.5941767906169857", "0.9"), "extrinsic.quaternion: must have unit norm"},
    {"ws_quaternion_short", replaced(kWoodScape, "0.5941767906169857, ", ""), "extrinsic.quaternion: expected 4"},
    {"ws_intrinsic_list", replaced(kWoodScape, "\"intrinsic\": {", "\"intrinsic\": [{"), "not valid JSON"},
    {"ws_huge", replaced(kWoodScape, "-7.201", "1e308"), "coefficients too large"},
    {"ws_rho_overflow", replaced(kWoodScape, "-7.201", "1e308"), "coefficients too large"},
    {"ws_top_array", "[\"intrinsic\"]", "expected a JSON object"},
    // fishcam JSON
    {"fc_model", replaced(kFishcam, "equidistant", "fisheye"), "model: unknown model 'fisheye'"},
    {"fc_params", replaced(kFishcam, "[340.0]", "[340.0, 1]"), "equidistant: expected 1 parameter(s) (f), got 2"},
    {"fc_version", replaced(kFishcam, "\"fishcam_camera\": 1", "\"fishcam_camera\": 9"), "fishcam_camera: unsupported"},
    {"fc_scale", replaced(kFishcam, "[1.0, 1.0]", "[1.0, 0.0]"), "pixel_scale"},
    {"fc_limit", replaced(kFishcam, "\"parameters\"", "\"theta_limit_deg\": 200, \"parameters\""),
     "theta_limit: must be in (0, 180]"},
    {"fc_limit_by_azimuth_short",
     replaced(kFishcam, "\"parameters\"", "\"theta_limit_by_azimuth_deg\": [10, 20], \"parameters\""),
     "theta_limit_by_azimuth_deg: expected 24"},
    {"fc_limit_by_azimuth_range",
     replaced(kFishcam, "\"parameters\"",
              "\"theta_limit_by_azimuth_deg\": [10,10,10,10,10,10,10,10,10,10,10,10,10,10,10,10,10,10,10,10,10,10,10,"
              "190], \"parameters\""),
     "theta_limit_by_azimuth: every sector's limit must be in [0, 180] degrees, got 190"},
    {"fc_pp_type", replaced(kFishcam, "[643.442, 479.407]", "\"centre\""), "principal_point: expected a list"},
    // mrcal
    {"mr_lensmodel", replaced(kMrcal, "'LENSMODEL_STEREOGRAPHIC'", "'LENSMODEL_CAHVOR7'"),
     "lensmodel: unsupported lens model 'LENSMODEL_CAHVOR7'"},
    {"mr_cahvor_values", replaced(kMrcal, "'LENSMODEL_STEREOGRAPHIC'", "'LENSMODEL_CAHVOR'"),
     "intrinsics: LENSMODEL_CAHVOR has 5 values after fx, fy, cx, cy, got 0"},
    {"mr_cahvore", replaced(kMrcal, "'LENSMODEL_STEREOGRAPHIC'", "'LENSMODEL_CAHVORE_linearity=0.00'"),
     "intrinsics: LENSMODEL_CAHVORE_linearity=0.00 has 8 values after fx, fy, cx, cy, got 0"},
    {"mr_intrinsics_short", replaced(kMrcal, "330, ", ""), "intrinsics: expected 4 numbers, got 3"},
    {"mr_nan", replaced(kMrcal, "330", "nan"), "intrinsics[0]: must be finite"},
    {"mr_truncated", kMrcal.substr(0, kMrcal.size() - 40), "not a valid mrcal .cameramodel"},
    {"mr_imagersize", replaced(kMrcal, "[ 1280, 966,]", "[ 1280, -966,]"),
     "imagersize: expected two positive integers"},
    {"mr_missing_imagersize", replaced(kMrcal, "'imagersize'", "'imagesize'"), "imagersize: missing"},
    {"mr_garbage", replaced(kMrcal, "'extrinsics':", "'extrinsics': @"), "not a valid mrcal .cameramodel (line"},
    {"mr_fx_negative", replaced(kMrcal, "330", "-330"), "intrinsics: fx and fy must be > 0"},
    // OpenCV
    {"cv_missing_D", replaced(kOpenCV, "D: !!opencv-matrix", "E: !!opencv-matrix"), "D: missing"},
    {"cv_skew", replaced(kOpenCV, "6.4344200000000001e+02, 0.,", "6.4344200000000001e+02, 0.5,"), "K: expected"},
    {"cv_nan", replaced(kOpenCV, "3.4651399999999999e-02", ".nan"), "D.data[0]: must be finite"},
    {"cv_width", replaced(kOpenCV, "image_width: 1280", "image_width: wide"), "image_width: expected an integer"},
    {"cv_missing_height", replaced(kOpenCV, "image_height: 966", ""), "image_height: missing"},
    {"cv_truncated", kOpenCV.substr(0, kOpenCV.size() - 60), "not a readable YAML file"},
    {"cv_xml_truncated", "<?xml version=", "not a readable XML file"},
    {"cv_xml_not_opencv", "<?xml version=\"1.0\"?><a>1</a>", "not an OpenCV YAML/XML file"},
    {"cv_yaml_deep", "%YAML:1.0\n---\nK: " + std::string(100000, '['), "nested deeper than"},
    {"cv_newline_in_value", replaced(kOpenCV, "image_width: 1280", "image_width: \"12\\n80\\r\\x01\""),
     "image_width: expected an integer, got '12\\n80\\r\\x01'"},
    {"cv_model", replaced(kOpenCV, "distortion_model: fisheye", "distortion_model: fisheye2"),
     "distortion_model: expected fisheye, plumb_bob or rational_polynomial, got 'fisheye2'"},
    // anything else
    {"empty", "", "empty file"},
    {"unknown", "hello world\n", "unrecognised camera file"},
    {"binary", std::string("\x89PNG\r\n\x1a\n\0\0", 10), "unrecognised camera file"},
};

TEST(CameraIo, MalformedFilesGiveOneLineErrorsNamingFileAndField) {
  const auto dir = test::scratch_dir("malformed");
  for (const Malformed& m : kMalformed) {
    const auto path = test::write_file(dir / m.name, m.content);
    try {
      read_camera(path);
      ADD_FAILURE() << m.name << ": accepted";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << m.name << ": " << what;
      EXPECT_EQ(what.rfind(path.string(), 0), 0u) << m.name << ": " << what;
      EXPECT_NE(what.find(m.expected), std::string::npos) << m.name << ": " << what;
    }
  }
}

// Every prefix of every bundled file, and single-byte corruptions of them: a clean
// Error or a valid camera, never a crash or another exception.
TEST(CameraIo, TruncatedAndCorruptedFilesNeverCrash) {
  long errors = 0, parsed = 0;
  for (const auto& [name, format] : kBundled) {
    const std::string content = test::read_file(data_path(name));
    for (size_t cut = 0; cut < content.size(); cut += 3) {
      for (const std::string& variant :
           {content.substr(0, cut), content.substr(0, cut) + "\x01" + content.substr(cut + 1),
            content.substr(0, cut) + "}" + content.substr(cut + 1)}) {
        try {
          Camera camera(parse_camera(variant, name));
          ++parsed;
        } catch (const Error& e) {
          ASSERT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
          ++errors;
        }
      }
    }
  }
  EXPECT_GT(errors, 1000);
  EXPECT_GT(parsed, 10);  // some corruptions only touch comments or digits
}

// The same camera as OpenCV XML (written by cv::FileStorage, whose writer is safe):
// it reads back, and none of its prefixes or one-byte corruptions crash the reader
// (cv::FileStorage's own XML parser segfaulted on 5 of its 885 prefixes).
TEST(CameraIo, OpenCvXmlReadsAndItsPrefixesNeverCrash) {
  const Camera yaml = read_camera(data_path("kannala_brandt.yaml"));
  cv::FileStorage fs(".xml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  const auto p = yaml.parameters();
  const auto kb = model_params(p.model);
  fs << "distortion_model"
     << "fisheye"
     << "image_width" << p.width << "image_height" << p.height;
  fs << "K"
     << cv::Mat(cv::Matx33d(kb[0], 0, p.grid.principal_point.x(), 0, kb[0] * p.grid.pixel_scale.y(),
                            p.grid.principal_point.y(), 0, 0, 1));
  fs << "D" << cv::Mat(cv::Matx41d(kb[1], kb[2], kb[3], kb[4]));
  const std::string xml = fs.releaseAndGetString();
  ASSERT_EQ(xml.rfind("<?xml", 0), 0u);
  const CameraParameters back = parse_camera(xml, "k.xml");
  EXPECT_EQ(model_params(back.model), kb);
  EXPECT_EQ(back.grid.principal_point, p.grid.principal_point);
  long errors = 0;
  for (size_t cut = 0; cut < xml.size(); ++cut) {
    for (const std::string& variant : {xml.substr(0, cut), xml.substr(0, cut) + "<" + xml.substr(cut + 1)}) {
      try {
        parse_camera(variant, "k.xml");
      } catch (const Error& e) {
        ASSERT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
        ++errors;
      }
    }
  }
  EXPECT_GT(errors, long(xml.size()));
}

TEST(CameraIo, MissingFilesAndDirectories) {
  const auto dir = test::scratch_dir("missing");
  EXPECT_THROW(read_camera(dir / "nope.json"), Error);
  EXPECT_THROW(read_camera(dir), Error);
}

}  // namespace
}  // namespace fishcam

namespace fishcam {
namespace {

// A camera that reads fine but whose rescaled parameters overflow in a format
// (WoodScape and OpenCV store a_x = 1): refused at write time, not written as a
// file that no reader takes.
TEST(CameraIo, WritersRefuseWhatTheReadersWouldRefuse) {
  CameraParameters p = test::woodscape_front();
  p.model = Equidistant<double>(1e300);
  p.grid.pixel_scale = {1e10, 1e10};
  ASSERT_NO_THROW(Camera{p});
  // Readers refuse magnitudes no camera has (a pixel scale past 1e6), so every
  // writer refuses to write them, fishcam JSON too.
  for (CameraFormat format : {CameraFormat::woodscape, CameraFormat::opencv, CameraFormat::fishcam}) {
    try {
      format_camera(p, format);
      ADD_FAILURE() << to_string(format) << ": wrote it";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("format cannot hold this camera"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace fishcam
