// Single-view initialisation of an FSP landmark from the four image corners of a rectangle,
// anchored at the observing camera (F = C). Zhang & He, "Whiteboard scanning and image enhancement"
// (2007), the rectangle / aspect-ratio part, with the calibrated K (never the focal length Zhang-He
// can estimate). backend/README.md, "Landmark models".
//
// With homogeneous undistorted pixels m_i (s1..s4 order) and m̃_i = K⁻¹ m_i, the corners are P_i =
// λ_i m̃_i. A parallelogram has P1 + P3 = P2 + P4; fixing λ1 = 1 (s1 at unit depth: exactly the FSP
// scale) gives
//   c2 = λ2 = ((m̃1 × m̃3)·m̃4) / ((m̃2 × m̃3)·m̃4),   c4 = λ4 = ((m̃1 × m̃3)·m̃2) / ((m̃4 × m̃3)·m̃2),
//   λ3 = c2 + c4 − 1 (z of P3 = P2 + P4 − P1),
//   n2 = c2 m̃2 − m̃1 = R_F_O s̄2 (width edge),  n4 = c4 m̃4 − m̃1 = R_F_O s̄4 (height edge),
//   w̄ = |n2|,  f = |n2| / |n4|,  R_F_O = Orthonormalize([n2/|n2|, n4/|n4|, n2×n4/|n2×n4|]),  r =
//   m̃1.
// |cos∠(n2, n4)| tests that the quadrilateral is the image of a rectangle (0 for an exact one); it
// is noisy for small targets, so the refined fit's reprojection RMS is the final rectangle test
// (Options). ω is not observable in one view: it comes from a class prior width (ω = w̄ / w_prior)
// or a default depth of the rectangle's centre (ω = a_centre,z / d). Then (R_F_O, r, w̄, f) are
// refined by least squares with FspAnchorFactor (8 residuals, 7 unknowns, log ω held constant).
//
// Near fronto-parallel views (small or far targets) the tilt of the plane is ill-conditioned and
// noise can flip the normal. For objects known to be vertical, pass the "up" direction (−gravity)
// in F: the initial R_F_O is then replaced by the nearest rotation whose y axis (the height edge,
// which points up for the corner order of docs/conventions.md) is exactly "up" — x from n2 made
// horizontal — and the refinement adds a soft prior |y_O − up_F| / σ_up. The tilt about the
// vertical axis stays as the image says; later views decide the rest.
#pragma once

#include <optional>
#include <string>

#include "fsp/backend/fsp_landmark.h"
#include "fsp/common/types.h"

namespace fsp::backend {

struct SingleViewInitOptions {
  // Typical object widths [m] for the ω prior (ω = w̄ / width). A wrong prior scales the whole
  // object (and its distance) but not its shape; parallax in later views fixes it.
  double width_door_m = 0.9;
  double width_window_m = 1.2;
  double width_cabinet_m = 0.6;
  double width_poster_m = 0.6;
  double width_tag_m = 0.16;
  // Depth of the rectangle's centre [m] assumed for kUnknown (and any class without a width above).
  double default_depth_m = 3.0;
  // Rectangle test, two stages. (1) Closed form: largest |cos∠(n2, n4)| accepted [-]. Exact
  // rectangles give 0, but the statistic is noisy: with 1 px corner noise a 30 px target reaches
  // 0.9, so with the refinement on this is only a pre-filter against clearly wrong quadrilaterals;
  // with refine = false it is the whole test (then use ~0.3).
  double max_abs_cos = 0.95;
  // (2) After the refinement (an exact rectangle fitted to the 4 corners, 1 redundant DoF): largest
  // RMS reprojection error per coordinate, in units of sigma_px [-]. For a true rectangle RMS ≈
  // σ·sqrt(χ²₁/8), below 1.2σ in 99.9 % of cases; a 60° parallelogram of 100 px gives tens of σ.
  double max_rms_sigma = 2.5;
  // Least-squares refinement of (R_F_O, r, w̄, f) on the one view.
  bool refine = true;
  int max_iterations = 20;
  // Corner noise [px]: whitening of the refinement (relative to up_sigma_rad) and scale of
  // max_rms_sigma.
  double sigma_px = 1.0;
  // Soft prior on the y axis when an up direction is given [rad].
  double up_sigma_rad = 0.02;
  // Smallest area of any triangle of three corners [px²]; below it three corners are (nearly)
  // collinear and the homography is degenerate.
  double min_triangle_area_px2 = 2.0;
  bool Check(std::string* why) const;
};

// Width prior for a class, or a negative value when the class has none (use default_depth_m).
double ClassWidthPrior(const SingleViewInitOptions& options, ObjectClass object_class);

struct SingleViewInitSummary {
  enum class Status { kSuccess, kDegenerate, kNotRectangle, kBehindCamera, kInvalidInput };
  Status status = Status::kInvalidInput;
  std::string reason;                        // empty on success
  FspLandmark landmark;                      // anchored at the observing camera (F = C)
  double abs_cos = 1.0;                      // |cos∠(n2, n4)| of the closed-form solution
  double c2 = 0.0, c4 = 0.0, lambda3 = 0.0;  // relative depths of s2, s4, s3 (s1 = 1)
  bool omega_from_class_prior = false;
  bool up_used = false;
  double up_angle_rad = 0.0;        // angle between the closed-form y axis and "up" (when given)
  double rms_px_closed_form = 0.0;  // reprojection RMS per coordinate before refinement [px]
  double rms_px = 0.0;              // after refinement [px]
  int iterations = 0;
  bool success() const { return status == Status::kSuccess; }
};

// corners_px: undistorted pixels in s1..s4 order. K: ideal pinhole (last row 0 0 1). up_F: optional
// unit "up" (−gravity) direction in the camera frame, only for vertical objects.
SingleViewInitSummary InitializeFspSingleView(const Corners& corners_px, const Mat3& K,
                                              ObjectClass object_class,
                                              const SingleViewInitOptions& options,
                                              const std::optional<Vec3>& up_F = std::nullopt);

}  // namespace fsp::backend
