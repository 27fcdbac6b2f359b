// Least-squares alignment of an estimated trajectory's positions to the reference's:
//   p_ref,i ≈ s R p_est,i + t
// SE3 and Sim3 by Umeyama (1991), posyaw (4-DoF: translation + yaw about the gravity axis z) in
// closed form.
#pragma once

#include <string>
#include <vector>

#include "fsp/common/geometry.h"

namespace fsp::eval {

enum class AlignMode {
  kSe3,     // rotation + translation (evo_ape --align): the gauge of a stereo/RGB-D estimate
  kPosYaw,  // yaw about z + translation (rpg "posyaw"): the 4 unobservable DoF of visual-inertial
            // odometry
  kSim3,  // rotation + translation + scale (evo_ape --align --correct_scale): monocular vision only
};
const char* ToString(AlignMode mode);  // "se3", "posyaw", "sim3"
// Parses "se3", "posyaw", "sim3"; false otherwise.
bool ParseAlignMode(const std::string& text, AlignMode* mode);

// The similarity that maps the estimate's world into the reference's: p_ref = s R p_est + t.
struct Alignment {
  AlignMode mode = AlignMode::kSe3;
  double scale = 1.0;  // s; exactly 1 unless kSim3
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();

  Vec3 Apply(const Vec3& p_est) const { return scale * (R * p_est) + t; }
  // Aligned pose: rotation R R_est, position s R p_est + t.
  Rigid3 Apply(const Rigid3& T_est) const {
    return Rigid3(R * T_est.R(), Apply(T_est.translation()));
  }
};

// Why an alignment could not be computed (empty when it could).
struct AlignResult {
  Alignment alignment;
  std::string failure;  // e.g. "degenerate: all estimated positions are collinear"
  bool ok() const { return failure.empty(); }
};

// Minimises Σ_i ‖s R est_i + t − ref_i‖² over the parameters MODE frees. REF and EST must have the
// same size (a programmer error otherwise); fewer than 3 points or degenerate geometry is a
// failure.
AlignResult AlignPoints(const std::vector<Vec3>& ref, const std::vector<Vec3>& est, AlignMode mode);

}  // namespace fsp::eval
