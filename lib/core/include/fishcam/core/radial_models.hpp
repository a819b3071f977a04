// Radial projection models rho(theta): image distance from the principal point
// (in pixel-scale units, see docs/conventions.md) as a function of the angle of
// incidence theta. The list of models is in fishcam/core/model_registry.hpp, which
// says how to add one.
//
// One small class per model, templated on the scalar type so that Ceres can
// differentiate through them (ceres::Jet). Math calls are unqualified after a
// `using std::...` so that ADL picks the Jet overloads.
//
// Each model provides
//   kName, kParamNames               its name (CLI, files, Python) and parameters, in order
//   Model(const Scalar* p, int n)    from its parameters (n: their count; checked by the registry)
//   params()                         the parameters in that order
//   invalid()                        what is wrong with the parameters ("" if nothing); the
//                                    registry and Camera refuse a model with a problem
//   rho(theta), drho(theta)          the model and its analytic derivative
//   (optionally rho(theta, &drho)    both at once, where that is cheaper)
//   theta_limit(), limit_is_open()   where the model itself stops: theta < limit (open) or
//                                    <= limit (closed). Closed-form models include their own
//                                    folds here; compute_domain() also searches for folds
//   scaled(s)                        the model for s * rho(theta), exactly
//   initial_params(f)                a start whose rho'(0) = f (fitting, calibration)
// and optionally
//   theta_from_rho(rho)              a closed-form inverse on the valid domain
//   power_coefficients()             rho as a polynomial in theta (exact fold search)
//   basis(theta, n, g), from_basis   rho linear in the parameters: exact linear fits
//   fit_starts(f), param_bounds(i)   otherwise: where the non-linear fit starts, and its bounds
//   unified_form()                   the float warp kernel's unified-camera form (below)
//   from_paper(rho, theta)           the paper's closed-form conversion (its eqs. 13-14): the
//                                    model whose image has radius rho at angle theta
//   kTakesOrder                      the model's name takes a parameter count ("polynomial:6")
#pragma once

// One header per model (fishcam/core/models/), in the registry's order.
#include "fishcam/core/models/double_sphere.hpp"
#include "fishcam/core/models/equidistant.hpp"
#include "fishcam/core/models/extended_unified.hpp"
#include "fishcam/core/models/kannala_brandt.hpp"
#include "fishcam/core/models/mei.hpp"
#include "fishcam/core/models/ocam.hpp"
#include "fishcam/core/models/opencv.hpp"
#include "fishcam/core/models/pinhole.hpp"
#include "fishcam/core/models/polynomial.hpp"
#include "fishcam/core/models/stereographic.hpp"
#include "fishcam/core/models/unified.hpp"
