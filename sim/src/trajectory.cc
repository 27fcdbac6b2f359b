#include "fsp/sim/trajectory.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Dense>

#include "fsp/common/error.h"

namespace fsp::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Falling factorial n (n-1) ... (n-k+1): the factor of s^(n-k) in the k-th derivative of s^n.
double FallingFactorial(int n, int k) {
  double f = 1.0;
  for (int i = 0; i < k; ++i) f *= static_cast<double>(n - i);
  return f;
}

Vec4 Flat(const Waypoint& w) {
  return Vec4(w.p_W.x(), w.p_W.y(), w.p_W.z(), w.yaw_rad);
}

// Binomial coefficient n over k.
double Binomial(int n, int k) {
  double b = 1.0;
  for (int i = 1; i <= k; ++i) b = b * (n - k + i) / i;
  return b;
}

// The basis matrix of a uniform B-spline of degree D (order K = D + 1) in the power basis (Qin,
// "General matrix representations for B-splines", The Visual Computer 16, 2000, eq. 3): on a
// segment, y(s) = sum_i s^i sum_j M(i, j) c_j over its K control points, s in [0, 1], with
//   M(i, j) = C(K-1, i) / (K-1)! sum_{l=j}^{K-1} (-1)^(l-j) C(K, l-j) (K-1-l)^(K-1-i).
template <int D>
Eigen::Matrix<double, D + 1, D + 1> UniformBSplineBasis() {
  constexpr int K = D + 1;
  double factorial = 1.0;
  for (int i = 2; i < K; ++i) factorial *= i;
  Eigen::Matrix<double, K, K> M;
  for (int i = 0; i < K; ++i) {
    for (int j = 0; j < K; ++j) {
      double sum = 0.0;
      for (int l = j; l < K; ++l)
        sum += ((l - j) % 2 ? -1.0 : 1.0) * Binomial(K, l - j) * std::pow(K - 1 - l, K - 1 - i);
      M(i, j) = Binomial(K - 1, i) / factorial * sum;
    }
  }
  return M;
}

bool IsStill(const Waypoint& a, const Waypoint& b) {
  return (a.p_W - b.p_W).norm() < 1e-9 && std::abs(a.yaw_rad - b.yaw_rad) < 1e-12;
}

}  // namespace

bool TrajectoryOptions::Check(std::string* why) const {
  auto fail = [&](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (!(pose_smoothing_s >= 0.0)) return fail("pose_smoothing_s must be >= 0");
  if (!(pose_knot_s > 0.0)) return fail("pose_knot_s must be > 0");
  if (!(min_thrust > 0.0 && min_thrust < kGravity)) return fail("min_thrust must be in (0, 9.81)");
  return true;
}

Trajectory Trajectory::FromWaypoints(const std::vector<Waypoint>& waypoints,
                                     const TrajectoryOptions& options) {
  std::string why;
  FSP_CHECK(options.Check(&why));
  if (waypoints.size() < 2) throw InputError("a trajectory needs at least 2 waypoints");
  for (size_t i = 0; i < waypoints.size(); ++i) {
    const Waypoint& w = waypoints[i];
    if (!std::isfinite(w.t_s) || !w.p_W.allFinite() || !std::isfinite(w.yaw_rad)) {
      throw InputError("waypoint " + std::to_string(i) + " is not finite");
    }
    if (i > 0 && !(w.t_s > waypoints[i - 1].t_s)) {
      throw InputError("waypoint times must strictly increase (waypoint " + std::to_string(i) +
                       " at t = " + std::to_string(w.t_s) + " s)");
    }
  }

  Trajectory traj;
  traj.knots_ = waypoints;
  // Unwrap yaw so that consecutive headings differ by at most pi (the shorter turn).
  for (size_t i = 1; i < traj.knots_.size(); ++i) {
    double& yaw = traj.knots_[i].yaw_rad;
    const double prev = traj.knots_[i - 1].yaw_rad;
    yaw = prev + std::remainder(yaw - prev, 2.0 * kPi);
  }
  const auto& k = traj.knots_;
  const size_t n = k.size();

  // Derivatives at each waypoint: velocity and acceleration of the parabola through the waypoint
  // and its neighbours (non-uniform spacing): with h0, h1 the neighbouring intervals and d0, d1 the
  // slopes,
  //   v = (h1 d0 + h0 d1) / (h0 + h1),   a = 2 (d1 - d0) / (h0 + h1);   jerk = 0.
  // Zero at the ends and next to a still segment (exact hover).
  std::vector<Vec4> vel(n, Vec4::Zero()), acc(n, Vec4::Zero()), jerk(n, Vec4::Zero());
  for (size_t i = 1; i + 1 < n; ++i) {
    if (IsStill(k[i - 1], k[i]) || IsStill(k[i], k[i + 1])) continue;
    const double h0 = k[i].t_s - k[i - 1].t_s, h1 = k[i + 1].t_s - k[i].t_s;
    const Vec4 d0 = (Flat(k[i]) - Flat(k[i - 1])) / h0, d1 = (Flat(k[i + 1]) - Flat(k[i])) / h1;
    vel[i] = (h1 * d0 + h0 * d1) / (h0 + h1);
    acc[i] = 2.0 * (d1 - d0) / (h0 + h1);
  }

  // Degree-7 Hermite segment in s = (t - t0) / T, y(s) = sum_n c_n s^n, with d^k y/dt^k = y^(k)(s)
  // / T^k: c0..c3 from the start (p, v T, a T^2 / 2, j T^3 / 6); c4..c7 solve the end conditions
  //   sum_n n!/(n-k)! c_n = (p1, v1 T, a1 T^2, j1 T^3)_k,  k = 0..3.
  Eigen::Matrix4d M;
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col) M(row, col) = FallingFactorial(col + 4, row);
  }
  const Eigen::Matrix4d M_inv = M.inverse();
  traj.segments_.reserve(n - 1);
  for (size_t i = 0; i + 1 < n; ++i) {
    Segment seg;
    seg.t0 = k[i].t_s;
    const double T = k[i + 1].t_s - k[i].t_s;
    seg.duration = T;
    const Vec4 p0 = Flat(k[i]), p1 = Flat(k[i + 1]);
    seg.c.setZero();
    seg.c.row(0) = p0.transpose();
    seg.c.row(1) = (vel[i] * T).transpose();
    seg.c.row(2) = (acc[i] * T * T / 2.0).transpose();
    seg.c.row(3) = (jerk[i] * T * T * T / 6.0).transpose();
    const Vec4 end_target[4] = {p1, vel[i + 1] * T, acc[i + 1] * T * T, jerk[i + 1] * T * T * T};
    Eigen::Matrix4d
        rhs;  // row k: end condition k minus the known coefficients' part; columns: outputs
    for (int kk = 0; kk < 4; ++kk) {
      Vec4 known = Vec4::Zero();
      for (int nn = kk; nn < 4; ++nn) known += FallingFactorial(nn, kk) * seg.c.row(nn).transpose();
      rhs.row(kk) = (end_target[kk] - known).transpose();
    }
    seg.c.bottomRows<4>() = M_inv * rhs;
    traj.segments_.push_back(seg);
  }

  traj.CheckThrust(options);
  return traj;
}

void Trajectory::CheckThrust(const TrajectoryOptions& options) const {
  // The flight must never need (near) free fall: check the thrust densely.
  for (const Segment& seg : segments_) {
    constexpr int kChecks = 64;
    for (int j = 0; j <= kChecks; ++j) {
      const double t = seg.t0 + seg.duration * j / kChecks;
      const Vec3 a = FlatDerivative(t, 2).head<3>();
      const double thrust = (a - GravityW()).norm();
      if (thrust < options.min_thrust) {
        std::ostringstream msg;
        msg << "the trajectory needs a thrust of " << thrust << " m/s^2 at t = " << t
            << " s (free fall; min " << options.min_thrust << "): slow down its vertical motion";
        throw InputError(msg.str());
      }
    }
  }
}

Trajectory Trajectory::FromPoses(const std::vector<StampedPose>& poses,
                                 const TrajectoryOptions& options) {
  std::string why;
  FSP_CHECK(options.Check(&why));
  if (poses.size() < 2) throw InputError("a pose trajectory needs at least 2 poses");
  const int64_t t0_ns = poses.front().t_ns;
  std::vector<double> t(poses.size()), yaw(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    int64_t dt_ns = 0;
    if (__builtin_sub_overflow(poses[i].t_ns, t0_ns, &dt_ns)) {
      throw InputError("pose " + std::to_string(i) + " is more than 292 years after the first");
    }
    t[i] = static_cast<double>(dt_ns) * 1e-9;
    if (i > 0 && !(t[i] > t[i - 1])) {
      throw InputError("pose times must strictly increase (pose " + std::to_string(i) + ")");
    }
    // Heading of the body x axis projected on the floor, unwrapped.
    const Vec3 x_W = poses[i].T_W_B.R().col(0);
    yaw[i] = std::atan2(x_W.y(), x_W.x());
    if (i > 0) yaw[i] = yaw[i - 1] + std::remainder(yaw[i] - yaw[i - 1], 2.0 * kPi);
  }
  const double span = t.back();
  const double intervals = std::floor(span / options.pose_knot_s + 1e-9);
  if (intervals < 1.0) throw InputError("the poses span less than one knot interval");
  if (intervals >= kMaxPoseKnots) {
    std::ostringstream os;
    os << "the poses span " << span << " s: more than " << kMaxPoseKnots
       << " knots of pose_knot_s = " << options.pose_knot_s << " s";
    throw InputError(os.str());
  }
  const int knots = static_cast<int>(intervals) + 1;

  // Each knot: Gaussian-weighted mean (sigma = pose_smoothing_s, window +-3 sigma) of the poses'
  // positions and yaw; without smoothing, linear interpolation between the neighbouring poses.
  std::vector<Waypoint> waypoints(knots);
  const double sigma = options.pose_smoothing_s;
  for (int kk = 0; kk < knots; ++kk) {
    const double tk = kk * options.pose_knot_s;
    Waypoint& w = waypoints[kk];
    w.t_s = tk;
    if (sigma > 0.0) {
      const auto lo = std::lower_bound(t.begin(), t.end(), tk - 3.0 * sigma) - t.begin();
      const auto hi = std::upper_bound(t.begin(), t.end(), tk + 3.0 * sigma) - t.begin();
      double wsum = 0.0;
      Vec3 p = Vec3::Zero();
      double y = 0.0;
      for (auto i = lo; i < hi; ++i) {
        const double wi = std::exp(-0.5 * (t[i] - tk) * (t[i] - tk) / (sigma * sigma));
        wsum += wi;
        p += wi * poses[i].T_W_B.translation();
        y += wi * yaw[i];
      }
      if (wsum > 0.0) {
        w.p_W = p / wsum;
        w.yaw_rad = y / wsum;
        continue;
      }
    }
    const size_t hi =
        std::min<size_t>(std::upper_bound(t.begin(), t.end(), tk) - t.begin(), t.size() - 1);
    const size_t lo = hi == 0 ? 0 : hi - 1;
    const double alpha = hi == lo ? 0.0 : std::clamp((tk - t[lo]) / (t[hi] - t[lo]), 0.0, 1.0);
    w.p_W = (1.0 - alpha) * poses[lo].T_W_B.translation() + alpha * poses[hi].T_W_B.translation();
    w.yaw_rad = (1.0 - alpha) * yaw[lo] + alpha * yaw[hi];
  }
  return FromControlPoints(waypoints, options);
}

Trajectory Trajectory::FromControlPoints(const std::vector<Waypoint>& control,
                                         const TrajectoryOptions& options) {
  // Control points c_m: the first and the last repeated kDegree more times, so the first and
  // the last segment are exact hovers. Segment j (duration T = pose_knot_s) starts at j T:
  //   y(s) = [1 s ... s^5] M [c_j .. c_{j+5}]^T.
  constexpr int kDegree = 5;
  std::vector<Vec4> c;
  for (int i = 0; i < kDegree; ++i) c.push_back(Flat(control.front()));
  for (const Waypoint& w : control) c.push_back(Flat(w));
  for (int i = 0; i < kDegree; ++i) c.push_back(Flat(control.back()));
  const Eigen::Matrix<double, kDegree + 1, kDegree + 1> M = UniformBSplineBasis<kDegree>();
  const double T = options.pose_knot_s;
  Trajectory traj;
  for (size_t j = 0; j + kDegree < c.size(); ++j) {
    Segment seg;
    seg.t0 = static_cast<double>(j) * T;
    seg.duration = T;
    Eigen::Matrix<double, kDegree + 1, 4> P;
    for (int m = 0; m <= kDegree; ++m) P.row(m) = c[j + m].transpose();
    seg.c.setZero();
    seg.c.topRows<kDegree + 1>() = M * P;
    traj.segments_.push_back(seg);
  }
  // The knots: the curve at the segments' ends (t_begin, t_end and the hover outside the span).
  for (size_t j = 0; j <= traj.segments_.size(); ++j) {
    const Segment& seg = traj.segments_[std::min(j, traj.segments_.size() - 1)];
    const Vec4 y = j < traj.segments_.size() ? Vec4(seg.c.row(0).transpose())
                                             : Vec4(seg.c.colwise().sum().transpose());
    Waypoint w;
    w.t_s = static_cast<double>(j) * T;
    w.p_W = y.head<3>();
    w.yaw_rad = y[3];
    traj.knots_.push_back(w);
  }
  traj.CheckThrust(options);
  return traj;
}

const Trajectory::Segment& Trajectory::SegmentAt(double t) const {
  // First segment whose end is >= t.
  auto it =
      std::lower_bound(segments_.begin(), segments_.end(), t,
                       [](const Segment& s, double value) { return s.t0 + s.duration < value; });
  if (it == segments_.end()) --it;
  return *it;
}

Vec4 Trajectory::FlatDerivative(double t, int k) const {
  FSP_CHECK(k >= 0 && k <= 4);
  FSP_CHECK(!segments_.empty());  // built by FromWaypoints / FromPoses
  if (t <= t_begin() || t >= t_end()) {
    // Outside the span the body holds the end pose: only the value is non-zero.
    if (k > 0) return Vec4::Zero();
    return Flat(t <= t_begin() ? knots_.front() : knots_.back());
  }
  const Segment& seg = SegmentAt(t);
  const double s = (t - seg.t0) / seg.duration;
  // d^k y / dt^k = sum_{n >= k} n!/(n-k)! c_n s^(n-k) / T^k  (Horner in s).
  Vec4 value = Vec4::Zero();
  for (int nn = 7; nn >= k; --nn)
    value = value * s + FallingFactorial(nn, k) * seg.c.row(nn).transpose();
  return value / std::pow(seg.duration, k);
}

TrajectoryState Trajectory::State(double t) const {
  const Vec4 d0 = FlatDerivative(t, 0), d1 = FlatDerivative(t, 1), d2 = FlatDerivative(t, 2),
             d3 = FlatDerivative(t, 3);
  TrajectoryState state;
  state.v_W = d1.head<3>();
  state.a_W = d2.head<3>();
  const Vec3 jerk = d3.head<3>();
  const double psi = d0[3], psi_dot = d1[3];

  // Thrust axis b3 = u / |u| with u = a - g; du/dt = jerk, so db3/dt = (I - b3 b3^T) jerk / |u|.
  const Vec3 u = state.a_W - GravityW();
  const double f = u.norm();
  FSP_CHECK(f > 1e-6);
  const Vec3 b3 = u / f;
  const Vec3 b3_dot = (jerk - b3 * b3.dot(jerk)) / f;
  // Heading: x_c = (cos psi, sin psi, 0); b2 = w / |w| with w = b3 x x_c; db2/dt = (I - b2 b2^T)
  // dw/dt / |w|.
  const Vec3 xc(std::cos(psi), std::sin(psi), 0.0);
  const Vec3 xc_dot = psi_dot * Vec3(-std::sin(psi), std::cos(psi), 0.0);
  const Vec3 w = b3.cross(xc);
  const double wn = w.norm();
  FSP_CHECK(wn >
            1e-6);  // body z horizontal along the heading: impossible with thrust >= min_thrust
  const Vec3 b2 = w / wn;
  const Vec3 w_dot = b3_dot.cross(xc) + b3.cross(xc_dot);
  const Vec3 b2_dot = (w_dot - b2 * b2.dot(w_dot)) / wn;
  // b1 = b2 x b3, db1/dt = db2/dt x b3 + b2 x db3/dt.
  const Vec3 b1 = b2.cross(b3);
  const Vec3 b1_dot = b2_dot.cross(b3) + b2.cross(b3_dot);

  Mat3 R_W_B, R_dot;
  R_W_B << b1, b2, b3;
  R_dot << b1_dot, b2_dot, b3_dot;
  // [w_B]x = R^T dR/dt (skew-symmetric up to rounding; take its antisymmetric part).
  const Mat3 Omega = R_W_B.transpose() * R_dot;
  state.w_B =
      0.5 * Vec3(Omega(2, 1) - Omega(1, 2), Omega(0, 2) - Omega(2, 0), Omega(1, 0) - Omega(0, 1));
  state.T_W_B = Rigid3(R_W_B, d0.head<3>());
  return state;
}

}  // namespace fsp::sim
