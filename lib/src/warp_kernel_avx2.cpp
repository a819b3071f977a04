// The warp kernel for AVX2 + FMA (8 floats per vector), compiled with -mavx2
// -mfma and used only where the CPU has them. CV_CPU_DISPATCH_MODE puts OpenCV's
// intrinsics in their own namespace, so nothing is shared with the baseline object.
// Outside OpenCV's own build its headers derive only SSE2 from the compiler's
// flags, so the instruction sets this file is compiled for are named here.
#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#define CV_SSE3 1
#define CV_SSSE3 1
#define CV_SSE4_1 1
#define CV_SSE4_2 1
#define CV_AVX 1
#define CV_FMA3 1
#define CV_AVX2 1
#endif
#define CV_CPU_DISPATCH_MODE AVX2
#define FISHCAM_KERNEL_ISA avx2
#include "warp_kernel_impl.hpp"

#include <cstring>

namespace fishcam::detail {
namespace {

#if defined(__AVX2__)
// cv::remap's bilinear interpolation of an 8-bit image, byte for byte. For 5
// fraction bits OpenCV's weight table is exactly 32 (32 - fx)(32 - fy), 32 fx (32 - fy),
// ... (scale 2^15, no rounding fix-up needed), so a channel is
// (sum of the four weights (32 - fx | fx)(32 - fy | fy) times the pixels + 512) >> 10.
// to_fixed_point clamps the maps onto the outer pixel centres, so a tap past the
// image's last column or row has weight 0: it is read from inside the image instead
// of the border value, which changes nothing. One pixel per 128-bit lane: pshufb
// pairs the two columns of each channel, pmaddubsw weighs them across (at most
// 255 * 32 per 16 bits), pmaddwd weighs the two rows and adds them.
template <int kChannels>
[[gnu::always_inline]] inline __m128i bilinear_pixel(const BilinearSource& src, int x0, int y0, unsigned fraction) {
  static_assert(kChannels == 1 || kChannels == 3 || kChannels == 4);
  const int fx = int(fraction & 31), fy = int(fraction >> 5);
  const std::size_t top_offset = std::size_t(y0) * src.step + std::size_t(x0) * kChannels;
  const std::size_t bottom_offset = y0 + 1 < src.height ? top_offset + src.step : top_offset;
  const unsigned char* top = src.data + top_offset;
  const unsigned char* bottom = src.data + bottom_offset;
  __m128i rows;
  if (bottom_offset + 8 <= std::size_t(src.end - src.data)) {
    rows = _mm_unpacklo_epi64(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(top)),
                              _mm_loadl_epi64(reinterpret_cast<const __m128i*>(bottom)));
  } else {  // the last pixels of the last row: copy what lies inside the image
    alignas(16) unsigned char bytes[16] = {};
    const int taps = (x0 + 1 < src.width ? 2 : 1) * kChannels;
    std::memcpy(bytes, top, std::size_t(taps));
    std::memcpy(bytes + 8, bottom, std::size_t(taps));
    rows = _mm_load_si128(reinterpret_cast<const __m128i*>(bytes));
  }
  // (c0 left, c0 right, c1 left, ...) for the top row in bytes 0-7, the bottom row in 8-15.
  const __m128i pairs = kChannels == 1   ? _mm_setr_epi8(0, 1, -1, -1, -1, -1, -1, -1, 8, 9, -1, -1, -1, -1, -1, -1)
                        : kChannels == 3 ? _mm_setr_epi8(0, 3, 1, 4, 2, 5, -1, -1, 8, 11, 9, 12, 10, 13, -1, -1)
                                         : _mm_setr_epi8(0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15);
  const __m128i across = _mm_maddubs_epi16(_mm_shuffle_epi8(rows, pairs), _mm_set1_epi16(short((fx << 8) | (32 - fx))));
  const __m128i columns = _mm_unpacklo_epi16(across, _mm_srli_si128(across, 8));  // (c0 top, c0 bottom, c1 top, ...)
  const __m128i sum = _mm_madd_epi16(columns, _mm_set1_epi32((fy << 16) | (32 - fy)));
  return _mm_srli_epi32(_mm_add_epi32(sum, _mm_set1_epi32(512)), 10);  // channels as 32-bit lanes
}

template <int kChannels>
void bilinear_8u_row(const BilinearSource& src, const short* fixed, const unsigned short* fractions, int w,
                     unsigned char* out) {
  const __m128i fill = _mm_setr_epi32(src.fill[0], src.fill[1], src.fill[2], src.fill[3]);
  auto pixel = [&](int u) {
    const short x0 = fixed[2 * u], y0 = fixed[2 * u + 1];
    return x0 == kOutsideFixed ? fill : bilinear_pixel<kChannels>(src, x0, y0, fractions[u]);
  };
  // Four pixels' channels packed to bytes (4 per pixel), then the first kChannels of each.
  const __m128i keep = kChannels == 1   ? _mm_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1)
                       : kChannels == 3 ? _mm_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1)
                                        : _mm_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  int u = 0;
  for (; u + 4 <= w; u += 4) {
    const __m128i bytes = _mm_packus_epi16(_mm_packs_epi32(pixel(u), pixel(u + 1)),
                                           _mm_packs_epi32(pixel(u + 2), pixel(u + 3)));
    alignas(16) unsigned char packed[16];
    _mm_store_si128(reinterpret_cast<__m128i*>(packed), _mm_shuffle_epi8(bytes, keep));
    std::memcpy(out + u * kChannels, packed, 4 * kChannels);
  }
  for (; u < w; ++u) {
    const __m128i bytes = _mm_packus_epi16(_mm_packs_epi32(pixel(u), fill), fill);
    alignas(16) unsigned char packed[16];
    _mm_store_si128(reinterpret_cast<__m128i*>(packed), bytes);
    std::memcpy(out + u * kChannels, packed, kChannels);
  }
}

void bilinear_8u(const BilinearSource& src, const short* fixed, const unsigned short* fractions, int w,
                 unsigned char* out) {
  switch (src.channels) {
    case 1: return bilinear_8u_row<1>(src, fixed, fractions, w, out);
    case 3: return bilinear_8u_row<3>(src, fixed, fractions, w, out);
    case 4: return bilinear_8u_row<4>(src, fixed, fractions, w, out);
  }
}
#else
constexpr auto bilinear_8u = nullptr;  // not an x86-64 build: cv::remap
#endif

}  // namespace

RangeKernel select_kernel_avx2(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  return avx2::select_kernel(prior, inside_sphere, kind, sampling);
}

GridRowLoops grid_row_loops_avx2() { return {avx2::interpolate4, avx2::to_fixed_point, bilinear_8u}; }

}  // namespace fishcam::detail
