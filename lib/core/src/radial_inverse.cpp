#include "fishcam/core/radial_inverse.hpp"

#include "fishcam/core/error.hpp"

namespace fishcam {

const char* to_string(ValidDomain::Limit limit) {
  switch (limit) {
    case ValidDomain::Limit::model:
      return "model";
    case ValidDomain::Limit::fold:
      return "fold";
    case ValidDomain::Limit::user:
      return "user";
    case ValidDomain::Limit::distortion_fold:
      return "distortion-fold";
  }
  return "?";
}

}  // namespace fishcam
