// Test oracles and synthetic data for tests and benchmarks (fishcam_testing: built
// with the project, never installed). Not part of the library's API.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "fishcam/core/board.hpp"
#include "fishcam/core/camera.hpp"
#include "fishcam/core/radial_inverse.hpp"

namespace fishcam::testing {

struct SyntheticBoards {
  std::vector<BoardObservation> observations;
  std::vector<BoardPose> poses;
};
// Observations of `count` boards by a known camera, spread over the whole field of
// view (the rim included), every corner inside the image; Gaussian pixel noise of
// sigma noise_px. Reproducible from the seed on any platform. partial: boards may
// leave the image (a ChArUco target's views): the corners inside it (3 px in) are
// kept with their ids, at least 40 % of the board over 2 rows and 2 columns.
SyntheticBoards synthesize_boards(const Camera& camera, const BoardSpec& board, int count, double noise_px,
                                  std::uint64_t seed, bool partial = false);

// A photograph of a chessboard (cols + 1 by rows + 1 squares, a white margin of one
// square around them, grey beyond) seen by the camera with the board at `pose`:
// each pixel the mean of supersample x supersample sub-pixel rays (the exact
// coverage of the squares, up to that sampling), 8-bit grayscale, then a Gaussian
// blur of blur_px and Gaussian noise of noise_dn grey levels (seeded). The board's
// inner corners project to camera.project(pose * corner): the truth to compare
// detectors with.
std::vector<std::uint8_t> render_board_image(const Camera& camera, const BoardSpec& board, const BoardPose& pose,
                                             int supersample, double blur_px, double noise_dn, std::uint64_t seed);
// A planar target's look: the grey level (0..255) at board coordinates (x, y) (z = 0),
// NaN off the target (the grey background).
using TargetPattern = std::function<double(double x, double y)>;
// render_board_image for any pattern (a ChArUco board: fishcam::CharucoTexture).
std::vector<std::uint8_t> render_target_image(const Camera& camera, const TargetPattern& pattern, const BoardPose& pose,
                                              int supersample, double blur_px, double noise_dn, std::uint64_t seed);

// theta for rho from the companion-matrix roots of rho(theta) - rho (polynomial-type
// models): an independent algebraic cross-check of the iterative solver. NaN when
// no real root lies in the domain.
double algebraic_theta(std::span<const double> power_coefficients, double rho, const ValidDomain& domain);

}  // namespace fishcam::testing
