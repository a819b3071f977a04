// read_png: the library's PNG reader decodes every kind of PNG file as cv::imread
// does (the reference: OpenCV's codecs), and a bad file is a one-line error.
#include <png.h>
#include <zlib.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "fishcam/io/png_image.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

namespace fs = std::filesystem;

cv::Mat random_image(int rows, int cols, int type, uint64_t seed) {
  cv::Mat m(rows, cols, type);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  return m;
}

std::string error_of(const fs::path& path, PngPixels pixels) {
  try {
    read_png(path, pixels);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// A palette PNG (8-bit indices), written with libpng's own simplified writer.
void write_palette_png(const fs::path& path, int width, int height) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = png_uint_32(width);
  image.height = png_uint_32(height);
  image.format = PNG_FORMAT_RGB_COLORMAP;
  image.colormap_entries = 16;
  std::vector<png_byte> colormap(16 * 3), indices(size_t(width) * size_t(height));
  for (size_t i = 0; i < colormap.size(); ++i) colormap[i] = png_byte(i * 37 % 256);
  for (size_t i = 0; i < indices.size(); ++i) indices[i] = png_byte(i * 7 % 16);
  ASSERT_NE(png_image_write_to_file(&image, path.c_str(), 0, indices.data(), 0, colormap.data()), 0) << image.message;
}

TEST(PngImage, DecodesEveryKindOfFileAsOpenCVDoes) {
  const fs::path dir = test::scratch_dir("png_image");
  struct Case {
    std::string name;
    cv::Mat pixels;
    std::vector<int> params;
  };
  const std::vector<Case> cases = {
      {"bgr8", random_image(37, 53, CV_8UC3, 1), {}},
      {"gray8", random_image(37, 53, CV_8UC1, 2), {}},
      {"bgra8", random_image(37, 53, CV_8UC4, 3), {}},
      {"bgr16", random_image(37, 53, CV_16UC3, 4), {}},
      {"gray16", random_image(37, 53, CV_16UC1, 5), {}},
      {"bgra16", random_image(37, 53, CV_16UC4, 6), {}},
      {"bilevel", random_image(37, 53, CV_8UC1, 7) > 127, {cv::IMWRITE_PNG_BILEVEL, 1}},
      {"gray8_uncompressed", random_image(37, 53, CV_8UC1, 8), {cv::IMWRITE_PNG_COMPRESSION, 0}},
  };
  int compared = 0;
  for (const auto& c : cases) {
    const fs::path path = dir / (c.name + ".png");
    ASSERT_TRUE(cv::imwrite(path.string(), c.pixels, c.params)) << c.name;
    const cv::Mat colour = read_png(path, PngPixels::bgr8);
    const cv::Mat reference = cv::imread(path.string(), cv::IMREAD_COLOR);
    ASSERT_EQ(colour.type(), CV_8UC3) << c.name;
    ASSERT_EQ(colour.size(), reference.size()) << c.name;
    EXPECT_EQ(cv::norm(colour, reference, cv::NORM_INF), 0) << c.name;
    if (c.pixels.type() == CV_8UC1 && c.name != "bilevel") {
      const cv::Mat gray = read_png(path, PngPixels::gray8);
      EXPECT_EQ(cv::norm(gray, cv::imread(path.string(), cv::IMREAD_UNCHANGED), cv::NORM_INF), 0) << c.name;
      EXPECT_EQ(cv::norm(gray, c.pixels, cv::NORM_INF), 0) << c.name;
    } else {
      EXPECT_NE(error_of(path, PngPixels::gray8).find("expected an 8-bit single-channel PNG"), std::string::npos)
          << c.name;
    }
    ++compared;
  }
  const fs::path palette = dir / "palette.png";
  write_palette_png(palette, 29, 31);
  EXPECT_EQ(cv::norm(read_png(palette, PngPixels::bgr8), cv::imread(palette.string(), cv::IMREAD_COLOR), cv::NORM_INF),
            0);
  ++compared;
  EXPECT_EQ(compared, int(cases.size()) + 1);
}

// The bytes of a PNG file whose IHDR says width x height (its CRC right), no data.
std::string png_header(uint32_t width, uint32_t height) {
  std::string ihdr = "IHDR";
  for (const uint32_t v : {width, height}) {
    for (int shift = 24; shift >= 0; shift -= 8) ihdr += char((v >> shift) & 0xff);
  }
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8-bit RGB, not interlaced
  const uLong crc = crc32(0, reinterpret_cast<const Bytef*>(ihdr.data()), uInt(ihdr.size()));
  std::string out = "\x89PNG\r\n\x1a\n";
  out += std::string("\x00\x00\x00\x0d", 4) + ihdr;
  for (int shift = 24; shift >= 0; shift -= 8) out += char((crc >> shift) & 0xff);
  return out;
}

TEST(PngImage, BadFilesAreOneLineErrorsNamingTheFile) {
  const fs::path dir = test::scratch_dir("png_image_bad");
  const fs::path good = dir / "good.png";
  ASSERT_TRUE(cv::imwrite(good.string(), random_image(40, 60, CV_8UC3, 9)));
  std::ifstream in(good, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto write = [&](const std::string& name, const std::string& content) {
    std::ofstream(dir / name, std::ios::binary) << content;
    return dir / name;
  };
  std::string flipped = bytes;
  flipped[bytes.size() / 2] = char(~flipped[bytes.size() / 2]);  // inside IDAT: its CRC fails
  const std::vector<std::pair<fs::path, std::string>> cases = {
      {dir / "missing.png", "missing.png: no such file"},
      {dir, "is a directory, not an image file"},
      {write("text.png", "not a png at all"), "text.png: not a PNG file"},
      {write("empty.png", ""), "empty.png: not a PNG file"},
      {write("truncated.png", bytes.substr(0, bytes.size() / 2)), "truncated.png: cannot read PNG ("},
      {write("flipped.png", flipped), "flipped.png: cannot read PNG ("},
      {write("huge.png", png_header(40000, 10)), "huge.png: cannot read PNG ("},
      {write("no_data.png", png_header(64, 64)), "no_data.png: cannot read PNG ("},
  };
  for (const auto& [path, expected] : cases) {
    const std::string message = error_of(path, PngPixels::bgr8);
    EXPECT_NE(message.find(expected), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

// encode_png writes what OpenCV's decoder and read_png read back byte for byte, a
// view with padded rows included; other kinds of image are refused.
TEST(PngImage, EncodedImagesDecodeToTheSamePixels) {
  const fs::path dir = test::scratch_dir("png_image_encode");
  const cv::Mat colour = random_image(37, 53, CV_8UC3, 11), grey = random_image(20, 31, CV_8UC1, 12);
  const cv::Mat view = random_image(50, 70, CV_8UC3, 13)(cv::Rect(3, 5, 41, 29));  // rows padded
  int cases = 0;
  for (const cv::Mat& image : {colour, grey, view}) {
    const std::string bytes = encode_png(image);
    const cv::Mat decoded = cv::imdecode(std::vector<uchar>(bytes.begin(), bytes.end()), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(decoded.type(), image.type());
    EXPECT_EQ(cv::norm(decoded, image, cv::NORM_INF), 0);
    const fs::path path = dir / ("image" + std::to_string(cases) + ".png");
    std::ofstream(path, std::ios::binary) << bytes;
    const cv::Mat read = read_png(path, image.channels() == 1 ? PngPixels::gray8 : PngPixels::bgr8);
    EXPECT_EQ(cv::norm(read, image, cv::NORM_INF), 0);
    ++cases;
  }
  EXPECT_EQ(cases, 3);
  for (const cv::Mat& bad :
       {cv::Mat(4, 4, CV_16UC1, cv::Scalar(1)), cv::Mat(4, 4, CV_8UC2, cv::Scalar(1)), cv::Mat()}) {
    EXPECT_THROW(encode_png(bad), Error);
  }
}

}  // namespace
}  // namespace fishcam
