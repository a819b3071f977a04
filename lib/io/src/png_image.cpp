#include "fishcam/io/png_image.hpp"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <vector>

#include "fishcam/core/error.hpp"
#include "fishcam/io/file_input.hpp"

namespace fishcam {

namespace {

constexpr png_uint_32 kMaxSide = 32768;

// libpng's structures and the file, released whatever happens.
struct PngFile {
  std::FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  char message[160] = "";
  ~PngFile() {
    png_destroy_read_struct(&png, &info, nullptr);
    if (file) std::fclose(file);
  }
};

void on_error(png_structp png, png_const_charp text) {
  auto* f = static_cast<PngFile*>(png_get_error_ptr(png));
  std::snprintf(f->message, sizeof f->message, "%s", text);
  png_longjmp(png, 1);
}

// Warnings (a damaged ancillary chunk, which libpng skips) are not errors.
void on_warning(png_structp, png_const_charp) {}

struct Layout {
  png_uint_32 width = 0, height = 0;
  int channels = 0;
  bool refused = false;  // not what PngPixels::gray8 takes
};

// libpng reports errors by longjmp to the setjmp below: the two functions that call
// it hold only trivially destructible objects, so nothing is skipped on the way.
bool read_header(PngFile& f, PngPixels pixels, Layout& layout) {
  if (setjmp(png_jmpbuf(f.png))) return false;
  png_read_info(f.png, f.info);
  const int color_type = png_get_color_type(f.png, f.info);
  const int bit_depth = png_get_bit_depth(f.png, f.info);
  if (pixels == PngPixels::gray8) {
    if (color_type != PNG_COLOR_TYPE_GRAY || bit_depth != 8 || png_get_valid(f.png, f.info, PNG_INFO_tRNS)) {
      layout.refused = true;
      return true;
    }
  } else {
    // What OpenCV's PNG decoder does for cv::IMREAD_COLOR.
    if (bit_depth == 16) png_set_strip_16(f.png);
    if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(f.png);
    if ((color_type & PNG_COLOR_MASK_COLOR) == 0) {
      if (bit_depth < 8) png_set_expand_gray_1_2_4_to_8(f.png);
      png_set_gray_to_rgb(f.png);
    }
    png_set_strip_alpha(f.png);
    png_set_bgr(f.png);
  }
  png_set_interlace_handling(f.png);
  png_read_update_info(f.png, f.info);
  layout.width = png_get_image_width(f.png, f.info);
  layout.height = png_get_image_height(f.png, f.info);
  layout.channels = png_get_channels(f.png, f.info);
  return true;
}

bool read_rows(PngFile& f, png_bytepp rows) {
  if (setjmp(png_jmpbuf(f.png))) return false;
  png_read_image(f.png, rows);
  png_read_end(f.png, nullptr);
  return true;
}

}  // namespace

cv::Mat read_png(const std::filesystem::path& path, PngPixels pixels) {
  const std::string name = path_for_message(path);
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec && ec != std::errc::no_such_file_or_directory) throw Error(name + ": " + ec.message());
  if (!std::filesystem::exists(status)) throw Error(name + ": no such file");
  check_bounded_file(path, std::size_t(2) << 30, "an image file");
  PngFile f;
  f.file = std::fopen(path.c_str(), "rb");
  if (!f.file) throw Error(name + ": cannot open");
  png_byte signature[8] = {};
  if (std::fread(signature, 1, sizeof signature, f.file) != sizeof signature || png_sig_cmp(signature, 0, 8) != 0) {
    throw Error(name + ": not a PNG file");
  }
  f.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &f, on_error, on_warning);
  if (f.png) f.info = png_create_info_struct(f.png);
  if (!f.png || !f.info) throw Error(name + ": cannot read PNG (out of memory)");
  png_init_io(f.png, f.file);
  png_set_sig_bytes(f.png, 8);
  png_set_user_limits(f.png, kMaxSide, kMaxSide);
  Layout layout;
  if (!read_header(f, pixels, layout)) throw Error(name + ": cannot read PNG (" + f.message + ")");
  if (layout.refused) throw Error(name + ": expected an 8-bit single-channel PNG (grey, no transparency)");
  cv::Mat image(int(layout.height), int(layout.width), CV_8UC(layout.channels));
  std::vector<png_bytep> rows(layout.height);
  for (png_uint_32 r = 0; r < layout.height; ++r) rows[r] = image.ptr<png_byte>(int(r));
  if (!read_rows(f, rows.data())) throw Error(name + ": cannot read PNG (" + f.message + ")");
  return image;
}

std::string encode_png(const cv::Mat& image) {
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3) || image.empty()) {
    throw Error("encode_png: expected a non-empty 8-bit image with 1 or 3 channels");
  }
  png_image header{};
  header.version = PNG_IMAGE_VERSION;
  header.width = png_uint_32(image.cols);
  header.height = png_uint_32(image.rows);
  header.format = image.channels() == 1 ? PNG_FORMAT_GRAY : PNG_FORMAT_BGR;
  const auto stride = png_int_32(image.step[0]);
  png_alloc_size_t size = 0;  // first the size, then the bytes (libpng's two-call form)
  if (!png_image_write_to_memory(&header, nullptr, &size, 0, image.data, stride, nullptr)) {
    throw Error(std::string("encode_png: ") + header.message);
  }
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&header, bytes.data(), &size, 0, image.data, stride, nullptr)) {
    throw Error(std::string("encode_png: ") + header.message);
  }
  bytes.resize(size);
  return bytes;
}

}  // namespace fishcam
