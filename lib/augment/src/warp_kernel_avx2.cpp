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

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace fishcam::detail {
namespace {

#if defined(__AVX2__)
// The second pass of bilinear_8u_row over n pixels: each pixel's taps (two rows of
// 8 bytes) weighed across and down, rounded, and its channels stored from pixel u0
// on: interleaved into out[0], or (kPlanar) channel c into out[c].
template <int kChannels, bool kPlanar>
[[gnu::always_inline]] inline void weigh_taps(const unsigned char* const* tops, const unsigned char* const* bottoms,
                                              const unsigned* across, const unsigned* down, int n,
                                              unsigned char* const* out, int u0) {
  // (c0 left, c0 right, c1 left, ...) for the top row in bytes 0-7, the bottom row in 8-15.
  const __m128i pairs = kChannels == 1   ? _mm_setr_epi8(0, 1, -1, -1, -1, -1, -1, -1, 8, 9, -1, -1, -1, -1, -1, -1)
                        : kChannels == 2 ? _mm_setr_epi8(0, 2, 1, 3, -1, -1, -1, -1, 8, 10, 9, 11, -1, -1, -1, -1)
                        : kChannels == 3 ? _mm_setr_epi8(0, 3, 1, 4, 2, 5, -1, -1, 8, 11, 9, 12, 10, 13, -1, -1)
                                         : _mm_setr_epi8(0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15);
  // Four pixels' channels packed to bytes (4 per pixel), then the first kChannels of
  // each, pixel after pixel -- or, for planes, channel after channel (4 bytes each).
  const __m128i keep = kPlanar          ? _mm_setr_epi8(0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15)
                       : kChannels == 1 ? _mm_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1)
                       : kChannels == 2 ? _mm_setr_epi8(0, 1, 4, 5, 8, 9, 12, 13, -1, -1, -1, -1, -1, -1, -1, -1)
                       : kChannels == 3 ? _mm_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1)
                                        : _mm_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m128i half = _mm_set1_epi32(512);
  auto pixel = [&](int j) {  // the channels as 32-bit lanes
    const __m128i rows = _mm_unpacklo_epi64(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(tops[j])),
                                            _mm_loadl_epi64(reinterpret_cast<const __m128i*>(bottoms[j])));
    const __m128i across_sum = _mm_maddubs_epi16(_mm_shuffle_epi8(rows, pairs), _mm_set1_epi32(int(across[j])));
    const __m128i columns = _mm_unpacklo_epi16(across_sum, _mm_srli_si128(across_sum, 8));  // (c0 top, c0 bottom, ...)
    const __m128i sum = _mm_madd_epi16(columns, _mm_set1_epi32(int(down[j])));
    return _mm_srli_epi32(_mm_add_epi32(sum, half), 10);
  };
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    const __m128i bytes =
        _mm_packus_epi16(_mm_packs_epi32(pixel(j), pixel(j + 1)), _mm_packs_epi32(pixel(j + 2), pixel(j + 3)));
    alignas(16) unsigned char packed[16];
    _mm_store_si128(reinterpret_cast<__m128i*>(packed), _mm_shuffle_epi8(bytes, keep));
    if constexpr (kPlanar) {
      for (int c = 0; c < kChannels; ++c) std::memcpy(out[c] + u0 + j, packed + 4 * c, 4);
    } else {
      std::memcpy(out[0] + (u0 + j) * kChannels, packed, 4 * kChannels);
    }
  }
  for (; j < n; ++j) {
    const __m128i bytes = _mm_packus_epi16(_mm_packs_epi32(pixel(j), half), half);
    alignas(16) unsigned char packed[16];
    _mm_store_si128(reinterpret_cast<__m128i*>(packed), bytes);
    if constexpr (kPlanar) {
      for (int c = 0; c < kChannels; ++c) out[c][u0 + j] = packed[c];
    } else {
      std::memcpy(out[0] + (u0 + j) * kChannels, packed, kChannels);
    }
  }
}

// cv::remap's bilinear interpolation of an 8-bit image, byte for byte. For 5
// fraction bits OpenCV's weight table is exactly 32 (32 - fx)(32 - fy), 32 fx (32 - fy),
// ... (scale 2^15, no rounding fix-up needed), so a channel is
// (sum of the four weights (32 - fx | fx)(32 - fy | fy) times the pixels + 512) >> 10.
// to_fixed_point clamps the maps onto the outer pixel centres, so a tap past the
// image's last column or row has weight 0: it is read from inside the image instead
// of the border value, which changes nothing.
//
// A row is done in chunks, in two passes: first, 8 pixels per step, each pixel's
// two row pointers and its weights; then the taps, without a branch (a loop doing
// both per pixel spent most of its instructions on scalar address arithmetic,
// branches and weight broadcasts; two passes are 14 % faster per sample). Pixels without a
// source point at a block of the fill value, which any weights reproduce. One
// pixel per 128-bit lane: pshufb pairs the two columns of each channel, pmaddubsw
// weighs them across (at most 255 * 32 per 16 bits), pmaddwd weighs the two rows
// and adds them.
template <int kChannels, bool kPlanar>
void bilinear_8u_row(const BilinearSource& src, const short* fixed, const unsigned short* fractions, int w,
                     unsigned char* const* out) {
  static_assert(kChannels >= 1 && kChannels <= 4);
  constexpr int kChunk = 64;
  alignas(32) const unsigned char* tops[kChunk];
  alignas(32) const unsigned char* bottoms[kChunk];
  alignas(32) unsigned across[kChunk];  // (32 - fx) | fx << 8, twice
  alignas(32) unsigned down[kChunk];    // (32 - fy) | fy << 16
  alignas(16) unsigned char fill[16];   // two pixels, two rows
  for (int k = 0; k < 8; ++k) fill[k] = fill[8 + k] = src.fill[k % kChannels];
  alignas(16) unsigned char edge[kChunk][16];  // the taps of pixels whose 8-byte reads would pass the image's end
  // Offsets in 32 bits: the caller takes this path only for images under 2 GiB.
  const __m256i step = _mm256_set1_epi32(int(src.step)), last_row = _mm256_set1_epi32(src.height - 1);
  const __m256i channels = _mm256_set1_epi32(kChannels), outside = _mm256_set1_epi32(kOutsideFixed);
  const __m256i last_read = _mm256_set1_epi32(int(src.end - src.data) - 8);
  const __m256i five_bits = _mm256_set1_epi32(31), steps = _mm256_set1_epi32(32);
  const __m256i base = _mm256_set1_epi64x(reinterpret_cast<long long>(src.data));
  const __m256i fill_pointer = _mm256_set1_epi64x(reinterpret_cast<long long>(fill));
  for (int u0 = 0; u0 < w; u0 += kChunk) {
    const int n = w - u0 < kChunk ? w - u0 : kChunk;  // (no std::min: this object shares no templates)
    // Whole vectors: the maps have room for 7 pixels past the row (their values are not used).
    for (int k = 0; 8 * k < n; ++k) {
      const int u = u0 + 8 * k;
      const __m256i xy = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(fixed + 2 * u));
      const __m256i x = _mm256_srai_epi32(_mm256_slli_epi32(xy, 16), 16), y = _mm256_srai_epi32(xy, 16);
      const __m256i fraction = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(fractions + u)));
      const __m256i fx = _mm256_and_si256(fraction, five_bits), fy = _mm256_srli_epi32(fraction, 5);
      const __m256i wx = _mm256_or_si256(_mm256_slli_epi32(fx, 8), _mm256_sub_epi32(steps, fx));
      _mm256_store_si256(reinterpret_cast<__m256i*>(across + 8 * k), _mm256_or_si256(wx, _mm256_slli_epi32(wx, 16)));
      _mm256_store_si256(reinterpret_cast<__m256i*>(down + 8 * k),
                         _mm256_or_si256(_mm256_slli_epi32(fy, 16), _mm256_sub_epi32(steps, fy)));
      const __m256i no_source = _mm256_cmpeq_epi32(x, outside);
      const __m256i top = _mm256_add_epi32(_mm256_mullo_epi32(y, step), _mm256_mullo_epi32(x, channels));
      const __m256i bottom = _mm256_add_epi32(top, _mm256_and_si256(_mm256_cmpgt_epi32(last_row, y), step));
      for (int half_vector = 0; half_vector < 2; ++half_vector) {
        const __m128i t = half_vector ? _mm256_extracti128_si256(top, 1) : _mm256_castsi256_si128(top);
        const __m128i b = half_vector ? _mm256_extracti128_si256(bottom, 1) : _mm256_castsi256_si128(bottom);
        const __m128i o = half_vector ? _mm256_extracti128_si256(no_source, 1) : _mm256_castsi256_si128(no_source);
        const __m256i to_fill = _mm256_cvtepi32_epi64(o);
        const int j = 8 * k + 4 * half_vector;
        _mm256_store_si256(reinterpret_cast<__m256i*>(tops + j),
                           _mm256_blendv_epi8(_mm256_add_epi64(base, _mm256_cvtepu32_epi64(t)), fill_pointer, to_fill));
        _mm256_store_si256(reinterpret_cast<__m256i*>(bottoms + j),
                           _mm256_blendv_epi8(_mm256_add_epi64(base, _mm256_cvtepu32_epi64(b)), fill_pointer, to_fill));
      }
      // The taps are waited for in the second pass (the loop is bound by their
      // latency there): ask for them now. Every other pixel's rows suffice, as
      // neighbours mostly share cache lines; all eight cost more than they saved.
      for (int lane = 0; lane < 8; lane += 2) {
        _mm_prefetch(reinterpret_cast<const char*>(tops[8 * k + lane]), _MM_HINT_T0);
        _mm_prefetch(reinterpret_cast<const char*>(bottoms[8 * k + lane]), _MM_HINT_T0);
      }
      // The image's last pixels: their taps are copied from inside it.
      const int lanes = n - 8 * k < 8 ? n - 8 * k : 8;
      const int past_end = _mm256_movemask_ps(_mm256_castsi256_ps(
                               _mm256_andnot_si256(no_source, _mm256_cmpgt_epi32(bottom, last_read)))) &
                           ((1 << lanes) - 1);
      for (int bits = past_end; bits; bits &= bits - 1) {
        const int lane = __builtin_ctz(unsigned(bits)), j = 8 * k + lane;
        const int taps = (fixed[2 * (u + lane)] + 1 < src.width ? 2 : 1) * kChannels;
        std::memset(edge[j], 0, sizeof edge[j]);
        std::memcpy(edge[j], tops[j], std::size_t(taps));
        std::memcpy(edge[j] + 8, bottoms[j], std::size_t(taps));
        tops[j] = edge[j];
        bottoms[j] = edge[j] + 8;
      }
    }
    weigh_taps<kChannels, kPlanar>(tops, bottoms, across, down, n, out, u0);
  }
}

template <bool kPlanar>
void bilinear_8u_as(const BilinearSource& src, const short* fixed, const unsigned short* fractions, int w,
                    unsigned char* const* out) {
  switch (src.channels) {
    case 1:
      return bilinear_8u_row<1, kPlanar>(src, fixed, fractions, w, out);
    case 2:
      return bilinear_8u_row<2, kPlanar>(src, fixed, fractions, w, out);
    case 3:
      return bilinear_8u_row<3, kPlanar>(src, fixed, fractions, w, out);
    case 4:
      return bilinear_8u_row<4, kPlanar>(src, fixed, fractions, w, out);
  }
}
void bilinear_8u(const BilinearSource& src, const short* fixed, const unsigned short* fractions, int w,
                 unsigned char* out) {
  bilinear_8u_as<false>(src, fixed, fractions, w, &out);
}
constexpr auto bilinear_8u_to_planes = bilinear_8u_as<true>;
#else
constexpr auto bilinear_8u = nullptr;  // not an x86-64 build: cv::remap
constexpr auto bilinear_8u_to_planes = nullptr;
#endif

}  // namespace

RangeKernel select_kernel_avx2(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  return avx2::select_kernel(prior, inside_sphere, kind, sampling);
}

GridRowLoops grid_row_loops_avx2() {
  return {avx2::interpolate4, avx2::to_fixed_point, bilinear_8u, bilinear_8u_to_planes};
}

}  // namespace fishcam::detail
