#include "fsp/backend/single_view_init.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>

#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/sized_cost_function.h>
#include <ceres/solver.h>

#include "fsp/backend/fsp_factor.h"
#include "fsp/common/error.h"

namespace fsp::backend {

bool SingleViewInitOptions::Check(std::string* why) const {
  auto fail = [why](const char* what) {
    if (why) *why = what;
    return false;
  };
  for (double w : {width_door_m, width_window_m, width_cabinet_m, width_poster_m, width_tag_m}) {
    if (!(w > 0.0) || !std::isfinite(w))
      return fail("class width priors must be positive and finite");
  }
  if (!(default_depth_m > 0.0) || !std::isfinite(default_depth_m))
    return fail("default_depth_m must be > 0");
  if (!(max_abs_cos > 0.0 && max_abs_cos <= 1.0)) return fail("max_abs_cos must be in (0, 1]");
  if (!(max_rms_sigma > 0.0)) return fail("max_rms_sigma must be > 0");
  if (max_iterations < 0) return fail("max_iterations must be >= 0");
  if (!(sigma_px > 0.0) || !std::isfinite(sigma_px)) return fail("sigma_px must be > 0");
  if (!(up_sigma_rad > 0.0) || !std::isfinite(up_sigma_rad))
    return fail("up_sigma_rad must be > 0");
  if (!(min_triangle_area_px2 >= 0.0)) return fail("min_triangle_area_px2 must be >= 0");
  return true;
}

double ClassWidthPrior(const SingleViewInitOptions& options, ObjectClass object_class) {
  switch (object_class) {
    case ObjectClass::kDoor:
      return options.width_door_m;
    case ObjectClass::kWindow:
      return options.width_window_m;
    case ObjectClass::kCabinet:
      return options.width_cabinet_m;
    case ObjectClass::kPoster:
      return options.width_poster_m;
    case ObjectClass::kTag:
      return options.width_tag_m;
    case ObjectClass::kUnknown:
      break;
  }
  return -1.0;
}

namespace {

using Mat34R = Eigen::Matrix<double, 3, 4, Eigen::RowMajor>;

// Soft "y axis is up" prior: e = (R_F_O e_y − up_F) / σ (3 residuals, rank 2).
// Left perturbation R -> Exp(φ) R: d(R e_y)/dφ = −[R e_y]×; ambient via
// LeftRotationJacobianWrtQuat.
class UpPrior final : public ceres::SizedCostFunction<3, 4> {
 public:
  UpPrior(const Vec3& up_F, double sigma) : up_(up_F), inv_sigma_(1.0 / sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* q = parameters[0];
    const Quat quat = Quat(q[3], q[0], q[1], q[2]).normalized();
    const Vec3 y = quat * Vec3::UnitY();
    Eigen::Map<Vec3> e(residuals);
    e = (y - up_) * inv_sigma_;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Mat34R> J(jacobians[0]);
      J = -inv_sigma_ * Skew(y) * LeftRotationJacobianWrtQuat(quat);
    }
    return true;
  }

 private:
  Vec3 up_;
  double inv_sigma_;
};

double RmsPx(const FspLandmark& l, const Corners& corners_px, const Mat3& K) {
  double ss = 0.0;
  for (int j = 0; j < 4; ++j)
    ss += (ProjectHomogeneous(K, l.CornerDirF(j)) - corners_px[j]).squaredNorm();
  return std::sqrt(ss / 8.0);
}

SingleViewInitSummary Fail(SingleViewInitSummary s, SingleViewInitSummary::Status status,
                           std::string reason) {
  s.status = status;
  s.reason = std::move(reason);
  return s;
}

}  // namespace

SingleViewInitSummary InitializeFspSingleView(const Corners& corners_px, const Mat3& K,
                                              ObjectClass object_class,
                                              const SingleViewInitOptions& options,
                                              const std::optional<Vec3>& up_F) {
  using Status = SingleViewInitSummary::Status;
  SingleViewInitSummary s;
  std::string why;
  if (!options.Check(&why)) return Fail(s, Status::kInvalidInput, "options: " + why);
  if (!K.allFinite() || !K.row(2).isApprox(Eigen::RowVector3d(0.0, 0.0, 1.0)) ||
      std::abs(K.determinant()) < 1e-12) {
    return Fail(s, Status::kInvalidInput,
                "K is not an invertible pinhole matrix with last row (0 0 1)");
  }
  for (const Vec2& c : corners_px) {
    if (!c.allFinite()) return Fail(s, Status::kInvalidInput, "corner is not finite");
  }
  if (up_F && (!up_F->allFinite() || up_F->norm() < 1e-9)) {
    return Fail(s, Status::kInvalidInput, "up direction is zero or not finite");
  }

  // Any three corners (nearly) collinear: degenerate.
  for (int skip = 0; skip < 4; ++skip) {
    Vec2 t[3];
    for (int i = 0, k = 0; i < 4; ++i) {
      if (i != skip) t[k++] = corners_px[i];
    }
    const Vec2 a = t[1] - t[0], b = t[2] - t[0];
    if (0.5 * std::abs(a.x() * b.y() - a.y() * b.x()) < options.min_triangle_area_px2) {
      return Fail(s, Status::kDegenerate, "three corners are (nearly) collinear");
    }
  }
  // m̃_i = K⁻¹ (u_i, v_i, 1).
  const Mat3 K_inv = K.inverse();
  Vec3 m[4];
  for (int i = 0; i < 4; ++i) m[i] = K_inv * Vec3(corners_px[i].x(), corners_px[i].y(), 1.0);
  const Vec3 m13 = m[0].cross(m[2]);
  const double den2 = m[1].cross(m[2]).dot(m[3]);
  const double den4 = m[3].cross(m[2]).dot(m[1]);
  // Zhang-He: relative depths with λ1 = 1 (header).
  s.c2 = m13.dot(m[3]) / den2;
  s.c4 = m13.dot(m[1]) / den4;
  s.lambda3 = s.c2 + s.c4 - 1.0;
  if (!(s.c2 > 0.0 && s.c4 > 0.0 && s.lambda3 > 0.0)) {
    return Fail(
        s, Status::kBehindCamera,
        "a corner would lie behind the camera (non-convex quadrilateral or wrong corner order)");
  }
  const Vec3 n2 = s.c2 * m[1] - m[0];
  const Vec3 n4 = s.c4 * m[3] - m[0];
  const double wbar = n2.norm();
  const double h_unit = n4.norm();
  if (!(wbar > 0.0) || !(h_unit > 0.0)) return Fail(s, Status::kDegenerate, "zero-length edge");
  s.abs_cos = std::abs(n2.dot(n4)) / (wbar * h_unit);
  if (s.abs_cos > options.max_abs_cos) {
    return Fail(s, Status::kNotRectangle,
                "edges are not perpendicular: |cos| = " + std::to_string(s.abs_cos) + " > " +
                    std::to_string(options.max_abs_cos));
  }
  const Vec3 ex = n2 / wbar;
  const Vec3 ey = n4 / h_unit;
  Mat3 M;
  M.col(0) = ex;
  M.col(1) = ey;
  M.col(2) = ex.cross(ey).normalized();
  Mat3 R_F_O = Orthonormalize(M);

  Vec3 up = Vec3::Zero();
  if (up_F) {
    up = up_F->normalized();
    s.up_angle_rad = std::acos(std::clamp(R_F_O.col(1).dot(up), -1.0, 1.0));
    // Nearest rotation with y = up: x = n2 made orthogonal to up.
    const Vec3 x_h = ex - ex.dot(up) * up;
    if (x_h.norm() > 1e-6) {
      R_F_O.col(0) = x_h.normalized();
      R_F_O.col(1) = up;
      R_F_O.col(2) = R_F_O.col(0).cross(up);
      s.up_used = true;
    }
  }

  // ω is irrelevant in this view (h = a): start at 1, set it from the prior after the refinement.
  s.landmark = FspLandmark::Make(R_F_O, m[0], 1.0, wbar, wbar / h_unit);
  s.rms_px_closed_form = RmsPx(s.landmark, corners_px, K);

  if (options.refine && options.max_iterations > 0) {
    FspFactorOptions fo;
    fo.sigma_px = options.sigma_px;
    ceres::Problem::Options po;
    ceres::Problem problem(po);
    problem.AddResidualBlock(new FspAnchorFactor(corners_px, K, fo), nullptr, s.landmark.q_F_O,
                             s.landmark.x);
    if (s.up_used)
      problem.AddResidualBlock(new UpPrior(up, options.up_sigma_rad), nullptr, s.landmark.q_F_O);
    problem.SetManifold(s.landmark.q_F_O, new ceres::EigenQuaternionManifold());
    problem.SetManifold(s.landmark.x, new ceres::SubsetManifold(5, {kFspLogOmega}));
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = options.max_iterations;
    so.num_threads = 1;
    so.logging_type = ceres::SILENT;
    so.minimizer_progress_to_stdout = false;
    so.function_tolerance = 1e-14;
    so.gradient_tolerance = 1e-14;
    so.parameter_tolerance = 1e-14;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    s.iterations = static_cast<int>(summary.iterations.size());
    // Keep unit norm in storage (Ceres' manifold keeps it up to rounding).
    Eigen::Map<Eigen::Vector4d>(s.landmark.q_F_O).normalize();
  }
  s.rms_px = RmsPx(s.landmark, corners_px, K);
  if (options.refine && options.max_iterations > 0 &&
      s.rms_px > options.max_rms_sigma * options.sigma_px) {
    return Fail(s, Status::kNotRectangle,
                "no rectangle fits the corners: RMS " + std::to_string(s.rms_px) + " px > " +
                    std::to_string(options.max_rms_sigma * options.sigma_px) + " px");
  }
  for (int j = 0; j < 4; ++j) {
    if (!(s.landmark.CornerDirF(j).z() > 0.0)) {
      return Fail(s, Status::kBehindCamera, "refined rectangle has a corner behind the camera");
    }
  }

  // ω from the class prior width (w = w̄/ω) or the default depth of the centre (depth = a_c,z / ω).
  const double wbar_ref = s.landmark.Wbar();
  const double width_prior = ClassWidthPrior(options, object_class);
  double omega;
  if (width_prior > 0.0) {
    omega = wbar_ref / width_prior;
    s.omega_from_class_prior = true;
  } else {
    const Mat3 R = s.landmark.R_F_O();
    const Vec3 a_centre = s.landmark.Ray() + R * (0.5 * (s.landmark.SBar(0) + s.landmark.SBar(2)));
    omega = a_centre.z() / options.default_depth_m;
  }
  s.landmark.x[kFspLogOmega] = std::log(omega);
  s.status = Status::kSuccess;
  return s;
}

}  // namespace fsp::backend
