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
#include <cstdlib>
#include <cstring>

namespace fishcam::detail {
namespace {

#if defined(__AVX2__)
// The second pass of bilinear_8u_row over n pixels: each pixel's taps (two rows of
// 8 bytes) weighed across and down, rounded, and its channels stored.
template <int kChannels>
[[gnu::always_inline]] inline void weigh_taps(const unsigned char* const* tops, const unsigned char* const* bottoms,
                                              const unsigned* across, const unsigned* down, int n,
                                              unsigned char* row_out) {
  // (c0 left, c0 right, c1 left, ...) for the top row in bytes 0-7, the bottom row in 8-15.
  const __m128i pairs = kChannels == 1   ? _mm_setr_epi8(0, 1, -1, -1, -1, -1, -1, -1, 8, 9, -1, -1, -1, -1, -1, -1)
                        : kChannels == 3 ? _mm_setr_epi8(0, 3, 1, 4, 2, 5, -1, -1, 8, 11, 9, 12, 10, 13, -1, -1)
                                         : _mm_setr_epi8(0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15);
  // Four pixels' channels packed to bytes (4 per pixel), then the first kChannels of each.
  const __m128i keep = kChannels == 1   ? _mm_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1)
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
    std::memcpy(row_out + j * kChannels, packed, 4 * kChannels);
  }
  for (; j < n; ++j) {
    const __m128i bytes = _mm_packus_epi16(_mm_packs_epi32(pixel(j), half), half);
    alignas(16) unsigned char packed[16];
    _mm_store_si128(reinterpret_cast<__m128i*>(packed), bytes);
    std::memcpy(row_out + j * kChannels, packed, kChannels);
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
template <int kChannels>
void bilinear_8u_row(const BilinearSource& src, const short* fixed, const unsigned short* fractions, int w,
                     unsigned char* out) {
  static_assert(kChannels == 1 || kChannels == 3 || kChannels == 4);
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
    weigh_taps<kChannels>(tops, bottoms, across, down, n, out + u0 * kChannels);
  }
}

void bilinear_8u(const BilinearSource& src, const short* fixed, const unsigned short* fractions, int w,
                 unsigned char* out) {
  switch (src.channels) {
    case 1:
      return bilinear_8u_row<1>(src, fixed, fractions, w, out);
    case 3:
      return bilinear_8u_row<3>(src, fixed, fractions, w, out);
    case 4:
      return bilinear_8u_row<4>(src, fixed, fractions, w, out);
  }
}
// bilinear_8u's arithmetic for channels-first images, 8 pixels at a time, in two
// passes per chunk of a row as bilinear_8u_row: first each pixel's top and bottom
// offsets and weights, with the planes' taps asked for; then, plane by plane, the
// two bytes at each offset (the pixel and its right neighbour) -- gathered
// (vpgatherdd: four bytes, a read that would pass the last row's end starting
// earlier and shifted back) or loaded one by one, whichever the CPU does faster
// (planar_taps_gathered) -- weighed across by pmaddubsw and down by pmaddwd, and 8
// output bytes stored into the plane. A pair at the last column is read one byte to
// the left with its weights swapped (the fraction there is 0: the right tap's weight
// is 0 anyway); pixels without a source read offset 0 and are replaced by the fill.
// So the planes are sampled where they lie, with no merge before and no split after.
// The first pass of bilinear_8u_planar_taps over pixels u0 .. u0 + n - 1 of a row:
// each pixel's top and bottom offsets, weights across and down and whether it has no
// source, into `chunk`; the planes' taps asked for.
struct PlanarChunk {
  static constexpr int kPixels = 64;
  alignas(32) int tops[kPixels], bottoms[kPixels], acrosses[kPixels], downs[kPixels], no_sources[kPixels];
};
[[gnu::always_inline]] inline void planar_offsets(const BilinearPlanes& src, const short* fixed,
                                                  const unsigned short* fractions, int w, int u0, int n,
                                                  PlanarChunk* chunk) {
  const __m256i outside = _mm256_set1_epi32(kOutsideFixed), five_bits = _mm256_set1_epi32(31);
  const __m256i steps = _mm256_set1_epi32(32), edge_across = _mm256_set1_epi32(32 << 8);
  const __m256i last_column = _mm256_set1_epi32(src.width - 1), last_row = _mm256_set1_epi32(src.height - 1);
  const __m256i step = _mm256_set1_epi32(int(src.step)), lane_index = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  int *tops = chunk->tops, *bottoms = chunk->bottoms;
  for (int j = 0; j < n; j += 8) {
    const int u = u0 + j, lanes = w - u < 8 ? w - u : 8;
    // The maps have room for 7 pixels past the row: their values are not used.
    const __m256i xy = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(fixed + 2 * u));
    __m256i x = _mm256_srai_epi32(_mm256_slli_epi32(xy, 16), 16), y = _mm256_srai_epi32(xy, 16);
    const __m256i unused = _mm256_cmpgt_epi32(lane_index, _mm256_set1_epi32(lanes - 1));
    const __m256i no_source = _mm256_or_si256(_mm256_cmpeq_epi32(x, outside), unused);
    x = _mm256_andnot_si256(no_source, x), y = _mm256_andnot_si256(no_source, y);
    const __m256i fraction = _mm256_andnot_si256(
        no_source, _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(fractions + u))));
    const __m256i fx = _mm256_and_si256(fraction, five_bits), fy = _mm256_srli_epi32(fraction, 5);
    const __m256i at_edge = _mm256_cmpeq_epi32(x, last_column);
    x = _mm256_add_epi32(x, at_edge);  // one to the left (at_edge is -1)
    const __m256i across =
        _mm256_blendv_epi8(_mm256_or_si256(_mm256_sub_epi32(steps, fx), _mm256_slli_epi32(fx, 8)), edge_across,
                           at_edge);  // bytes (32 - fx, fx, 0, 0)
    const __m256i top = _mm256_add_epi32(_mm256_mullo_epi32(y, step), x);
    _mm256_store_si256(reinterpret_cast<__m256i*>(tops + j), top);
    _mm256_store_si256(reinterpret_cast<__m256i*>(bottoms + j),
                       _mm256_add_epi32(top, _mm256_and_si256(_mm256_cmpgt_epi32(last_row, y), step)));
    _mm256_store_si256(reinterpret_cast<__m256i*>(chunk->acrosses + j), across);
    _mm256_store_si256(reinterpret_cast<__m256i*>(chunk->downs + j),
                       _mm256_or_si256(_mm256_sub_epi32(steps, fy), _mm256_slli_epi32(fy, 16)));
    _mm256_store_si256(reinterpret_cast<__m256i*>(chunk->no_sources + j), no_source);
    // Eight neighbouring pixels' taps mostly share a cache line per row and plane:
    // the first and the last pixel's are asked for.
    for (int c = 0; c < src.count; ++c) {
      for (const int lane : {j, j + lanes - 1}) {
        _mm_prefetch(reinterpret_cast<const char*>(src.planes[c] + tops[lane]), _MM_HINT_T0);
        _mm_prefetch(reinterpret_cast<const char*>(src.planes[c] + bottoms[lane]), _MM_HINT_T0);
      }
    }
  }
}

template <bool kGather>
void bilinear_8u_planar_taps(const BilinearPlanes& src, const short* fixed, const unsigned short* fractions, int w,
                             unsigned char* const* out) {
  const __m256i half = _mm256_set1_epi32(512), pair = _mm256_set1_epi32(0xffff);
  // The last offset a 4-byte gather may start at (width >= 4).
  const __m256i last_read = _mm256_set1_epi32(int(std::size_t(src.height - 1) * src.step) + src.width - 4);
  const __m256i low_dwords = _mm256_setr_epi32(0, 4, 0, 4, 0, 4, 0, 4);
  // The 8 bytes (one per pixel) of 8 32-bit lanes holding bytes.
  auto bytes_of = [&](__m256i lanes32) {
    const __m256i words = _mm256_packus_epi32(lanes32, lanes32);
    return _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_packus_epi16(words, words), low_dwords));
  };
  constexpr int kChunk = PlanarChunk::kPixels;
  PlanarChunk chunk;
  const int *tops = chunk.tops, *bottoms = chunk.bottoms;
  for (int u0 = 0; u0 < w; u0 += kChunk) {
    const int n = w - u0 < kChunk ? w - u0 : kChunk;
    planar_offsets(src, fixed, fractions, w, u0, n, &chunk);
    for (int j = 0; j < n; j += 8) {
      const int u = u0 + j, lanes = w - u < 8 ? w - u : 8;
      const auto load = [&](const int* values) { return _mm256_load_si256(reinterpret_cast<const __m256i*>(values)); };
      const __m256i across = load(chunk.acrosses + j), down = load(chunk.downs + j);
      const __m128i fill_lanes = bytes_of(_mm256_and_si256(load(chunk.no_sources + j), _mm256_set1_epi32(255)));
      const __m256i top = load(tops + j), bottom = load(bottoms + j);
      const __m256i top_read = _mm256_min_epi32(top, last_read), bottom_read = _mm256_min_epi32(bottom, last_read);
      const __m256i top_shift = _mm256_slli_epi32(_mm256_sub_epi32(top, top_read), 3);
      const __m256i bottom_shift = _mm256_slli_epi32(_mm256_sub_epi32(bottom, bottom_read), 3);
      // The weights across for a lane holding the top pair and the bottom pair.
      const __m256i across_both = _mm256_or_si256(across, _mm256_slli_epi32(across, 16));
      for (int c = 0; c < src.count; ++c) {
        // Per pixel, (top across, bottom across) as two 16-bit words, to be weighed down.
        __m256i rows;
        if constexpr (kGather) {  // each pixel's pair of bytes in the low half of its lane
          const int* plane = reinterpret_cast<const int*>(src.planes[c]);
          const __m256i top_taps =
              _mm256_and_si256(_mm256_srlv_epi32(_mm256_i32gather_epi32(plane, top_read, 1), top_shift), pair);
          const __m256i bottom_taps =
              _mm256_and_si256(_mm256_srlv_epi32(_mm256_i32gather_epi32(plane, bottom_read, 1), bottom_shift), pair);
          rows = _mm256_or_si256(_mm256_maddubs_epi16(top_taps, across),
                                 _mm256_slli_epi32(_mm256_maddubs_epi16(bottom_taps, across), 16));
        } else {  // the top pair and the bottom pair in one lane, weighed across at once
          alignas(32) unsigned taps[8];
          for (int l = 0; l < 8; ++l) {
            std::uint16_t top_pair, bottom_pair;
            std::memcpy(&top_pair, src.planes[c] + tops[j + l], 2);
            std::memcpy(&bottom_pair, src.planes[c] + bottoms[j + l], 2);
            taps[l] = unsigned(top_pair) | unsigned(bottom_pair) << 16;
          }
          rows = _mm256_maddubs_epi16(_mm256_load_si256(reinterpret_cast<const __m256i*>(taps)), across_both);
        }
        const __m256i value = _mm256_srli_epi32(_mm256_add_epi32(_mm256_madd_epi16(rows, down), half), 10);
        const __m128i bytes = _mm_blendv_epi8(bytes_of(value), _mm_set1_epi8(char(src.fill[c])), fill_lanes);
        if (lanes == 8) {
          _mm_storel_epi64(reinterpret_cast<__m128i*>(out[c] + u), bytes);
        } else {
          alignas(16) unsigned char last[16];
          _mm_store_si128(reinterpret_cast<__m128i*>(last), bytes);
          std::memcpy(out[c] + u, last, std::size_t(lanes));
        }
      }
    }
  }
}

// Gathers where they are fast (Intel since Skylake: the gathering kernel measured
// 1.11x the interleaved one there, the one-by-one loads 1.25-1.33x); loads elsewhere
// (AMD Zen 3: gathers 1.4-1.6x, loads 1.27-1.40x; docs/performance.md).
// FISHCAM_PLANAR_TAPS=gather or =loads chooses (how the tests cover both).
bool planar_taps_gathered() {
  if (const char* chosen = std::getenv("FISHCAM_PLANAR_TAPS")) {
    if (std::strcmp(chosen, "gather") == 0) return true;
    if (std::strcmp(chosen, "loads") == 0) return false;
  }
  __builtin_cpu_init();
  return __builtin_cpu_is("intel");
}
// (Chosen on the first call, from code that runs only where AVX2 is used.)
decltype(&bilinear_8u_planar_taps<true>) bilinear_8u_planar() {
  static const bool gathered = planar_taps_gathered();
  return gathered ? bilinear_8u_planar_taps<true> : bilinear_8u_planar_taps<false>;
}
#else
constexpr auto bilinear_8u = nullptr;  // not an x86-64 build: cv::remap
constexpr std::nullptr_t bilinear_8u_planar() { return nullptr; }
#endif

}  // namespace

RangeKernel select_kernel_avx2(DepthPrior prior, bool inside_sphere, SourceParams::Kind kind, bool sampling) {
  return avx2::select_kernel(prior, inside_sphere, kind, sampling);
}

GridRowLoops grid_row_loops_avx2() {
  return {avx2::interpolate4, avx2::to_fixed_point, bilinear_8u, bilinear_8u_planar()};
}

}  // namespace fishcam::detail
