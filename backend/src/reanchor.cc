#include "fsp/backend/reanchor.h"

#include <cmath>

#include "fsp/common/error.h"

namespace fsp::backend {

bool ReanchorFsp(const FspLandmark& in, const Rigid3& T_W_F, const Rigid3& T_W_Fnew,
                 FspLandmark* out, std::string* why) {
  FSP_CHECK(out != nullptr);
  const Rigid3 T_Fn_F = T_W_Fnew.Inverse() * T_W_F;
  const double omega = in.Omega();
  // q = s1 in F' (metric).
  const Vec3 q = T_Fn_F * (in.Ray() / omega);
  if (!(q.z() > kReanchorMinDepth) || !q.allFinite()) {
    if (why) *why = "s1 is not in front of the new anchor (depth " + std::to_string(q.z()) + " m)";
    return false;
  }
  const double omega_new = 1.0 / q.z();
  // Metric width kept: w̄' = (w̄/ω) ω'; log w̄' = log w̄ − log ω + log ω' (no exp/log round trip).
  const double log_wbar_new = in.x[kFspLogWbar] - in.x[kFspLogOmega] + std::log(omega_new);
  FspLandmark l =
      FspLandmark::Make(T_Fn_F.R() * in.R_F_O(), q * omega_new, omega_new, 1.0, in.Form());
  l.x[kFspLogWbar] = log_wbar_new;
  l.x[kFspLogForm] = in.x[kFspLogForm];
  *out = l;
  return true;
}

bool ReanchorFhp(const FhpLandmark& in, const Rigid3& T_W_F, const Rigid3& T_W_Fnew,
                 FhpLandmark* out, std::string* why) {
  FSP_CHECK(out != nullptr);
  const Rigid3 T_Fn_F = T_W_Fnew.Inverse() * T_W_F;
  FhpLandmark l;
  for (int j = 0; j < 4; ++j) {
    const Vec3 q = T_Fn_F * in.CornerF(j);
    if (!(q.z() > kReanchorMinDepth) || !q.allFinite()) {
      if (why) *why = "corner " + std::to_string(j + 1) + " is not in front of the new anchor";
      return false;
    }
    l.corner[j][0] = q.x() / q.z();
    l.corner[j][1] = q.y() / q.z();
    l.corner[j][2] = -std::log(q.z());
  }
  *out = l;
  return true;
}

}  // namespace fsp::backend
