#pragma once

#include <stdexcept>
#include <string>

namespace fishcam {

// Every failure the library reports: a one-line message naming what was wrong
// ("front.json: intrinsic.k1: expected a number, got string").
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace fishcam
