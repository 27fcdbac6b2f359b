// Exact re-anchoring of rectangle landmarks: move the anchor from camera frame F to another
// keyframe's camera frame F' (e.g. when F leaves the sliding window) without changing the geometry,
// so every predicted corner in every camera is unchanged (up to rounding).
//
// FSP (fsp_landmark.h): with T_F'_F = T_W_F'⁻¹ T_W_F and q = T_F'_F (r / ω) (s1 in F'):
//   ω' = 1 / q_z,  r' = q ω',  R_F'_O = R_F'_F R_F_O,  w̄' = w̄ ω'/ω (the metric width w̄/ω is kept),
//   f' = f.
// Then p_F'(s_j) = (r' + R_F'_O s̄'_j)/ω' = q + R_F'_F R_F_O s̄_j/ω = T_F'_F p_F(s_j) for every
// corner. FHP: each corner independently, q_j = T_F'_F (r_j / ω_j), ω'_j = 1/q_j,z, r'_j = q_j
// ω'_j. Requires s1 (FSP) or every corner (FHP) in front of F' (q_z > 0): the representation has ω
// > 0.
#pragma once

#include <string>

#include "fsp/backend/fsp_landmark.h"

namespace fsp::backend {

// False (and *why) when s1 is not in front of the new anchor; *out is then untouched.
bool ReanchorFsp(const FspLandmark& in, const Rigid3& T_W_F, const Rigid3& T_W_Fnew,
                 FspLandmark* out, std::string* why = nullptr);
bool ReanchorFhp(const FhpLandmark& in, const Rigid3& T_W_F, const Rigid3& T_W_Fnew,
                 FhpLandmark* out, std::string* why = nullptr);

// Smallest depth [m] accepted for the re-anchored s1 / corners in F'.
inline constexpr double kReanchorMinDepth = 1e-6;

}  // namespace fsp::backend
