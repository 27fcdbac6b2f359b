#include "fsp/backend/visual_sfm.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <utility>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "fsp/backend/imu_preintegration.h"
#include "fsp/common/median.h"

namespace fsp::backend {

bool VisualSfmOptions::Check(std::string* why) const {
  std::ostringstream os;
  if (!(keyframe_parallax_px > 0.0) || !(max_keyframe_interval_s > 0.0) || !(min_parallax_px > 0.0))
    os << "keyframe_parallax_px, max_keyframe_interval_s and min_parallax_px must be > 0";
  else if (min_points < 8 || min_pnp_points < 6 || min_keyframes < 3 || max_pairs < 1)
    os << "min_points must be >= 8, min_pnp_points >= 6, min_keyframes >= 3, max_pairs >= 1";
  else if (!(ransac_px > 0.0) || !(max_reprojection_px > 0.0) || !(max_rms_px > 0.0) ||
           !(huber_px > 0.0))
    os << "ransac_px, max_reprojection_px, max_rms_px and huber_px must be > 0";
  else if (!(max_rotation_error_deg > 0.0) || !(max_gyro_bias >= 0.0) ||
           !(min_ray_angle_deg >= 0.0))
    os << "max_rotation_error_deg must be > 0, max_gyro_bias and min_ray_angle_deg >= 0";
  else if (ba_iterations < 1)
    os << "ba_iterations must be >= 1";
  else if (!(keyframe_min_tracked >= 0.0 && keyframe_min_tracked <= 1.0) || !(min_span_s >= 0.0))
    os << "keyframe_min_tracked must be in [0, 1], min_span_s >= 0";
  if (why) *why = os.str();
  return os.str().empty();
}

namespace {

using PointMap = std::map<int64_t, Vec2>;  // point id -> undistorted pixel

constexpr double kDeg = M_PI / 180.0;

// Rotation-compensated median parallax [px] of the points A and B share: B's pixel rotated into
// A's camera by R_Ca_Cb (the infinite homography K R K^-1), against A's pixel.
double MedianParallax(const PointMap& a, const PointMap& b, const Mat3& K, const Mat3& Kinv,
                      const Mat3& R_Ca_Cb, int* shared) {
  std::vector<double> d;
  const Mat3 H = K * R_Ca_Cb * Kinv;
  for (const auto& [id, uv_b] : b) {
    const auto it = a.find(id);
    if (it == a.end()) continue;
    const Vec3 y = H * uv_b.homogeneous();
    d.push_back((y.head<2>() / y.z() - it->second).norm());
  }
  *shared = static_cast<int>(d.size());
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

// A keyframe's camera pose T_C_S, once known.
struct Pose {
  bool known = false;
  Rigid3 T_C_S;
};

// The parallax no rotation explains [px]: the median angle between A's bearings and B's rotated
// by the rotation that best aligns them (Kabsch on the unit bearings of the points A and B share),
// times the focal length. Unlike the gyroscope's compensation it does not depend on the bias (an
// unknown bias of 0.02 rad/s over 1.5 s is 17 px at f = 400): a pure rotation gives ~the noise.
double RotationFreeParallax(const PointMap& a, const PointMap& b, const Mat3& Kinv, double f,
                            int* shared) {
  std::vector<std::pair<Vec3, Vec3>> ab;
  for (const auto& [id, uv_b] : b) {
    const auto it = a.find(id);
    if (it != a.end())
      ab.emplace_back((Kinv * it->second.homogeneous()).normalized(),
                      (Kinv * uv_b.homogeneous()).normalized());
  }
  *shared = static_cast<int>(ab.size());
  if (ab.size() < 3) return 0.0;
  Mat3 M = Mat3::Zero();
  for (const auto& [fa, fb] : ab) M += fa * fb.transpose();
  const Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Mat3 R_a_b = svd.matrixU() * D * svd.matrixV().transpose();
  std::vector<double> d;
  for (const auto& [fa, fb] : ab) d.push_back(f * fa.cross(R_a_b * fb).norm());
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

struct Track {
  std::vector<std::pair<int, Vec2>> views;  // (keyframe slot, normalised coordinates)
  bool triangulated = false;
  Vec3 X = Vec3::Zero();  // in S
};

// Pixel reprojection error of X_S in a camera T_C_S at normalised coordinates x.
double ReprojectionPx(const Rigid3& T_C_S, const Vec3& X_S, const Vec2& x, double f) {
  const Vec3 p = T_C_S * X_S;
  if (!(p.z() > 1e-9)) return std::numeric_limits<double>::infinity();
  return f * (p.head<2>() / p.z() - x).norm();
}

// Linear (DLT) triangulation from every posed view; false when cheirality, reprojection or the
// ray angle fail.
bool Triangulate(Track* tr, const std::vector<Pose>& T_C_S, double f, const VisualSfmOptions& o) {
  std::vector<std::pair<const Rigid3*, Vec2>> v;
  for (const auto& [k, x] : tr->views)
    if (T_C_S[k].known) v.emplace_back(&T_C_S[k].T_C_S, x);
  if (v.size() < 2) return false;
  Eigen::MatrixXd A(2 * v.size(), 4);
  for (size_t i = 0; i < v.size(); ++i) {
    Eigen::Matrix<double, 3, 4> P;
    P << v[i].first->R(), v[i].first->translation();
    A.row(2 * i) = v[i].second.x() * P.row(2) - P.row(0);
    A.row(2 * i + 1) = v[i].second.y() * P.row(2) - P.row(1);
  }
  const Eigen::Vector4d h =
      Eigen::JacobiSVD<Eigen::MatrixXd>(A, Eigen::ComputeFullV).matrixV().col(3);
  if (std::abs(h[3]) < 1e-12) return false;
  const Vec3 X = h.head<3>() / h[3];
  for (const auto& [T, x] : v)
    if (!(ReprojectionPx(*T, X, x, f) <= o.max_reprojection_px)) return false;
  const Vec3 c0 = v.front().first->Inverse().translation();
  const Vec3 c1 = v.back().first->Inverse().translation();
  const double cosang = (X - c0).normalized().dot((X - c1).normalized());
  if (!(std::acos(std::clamp(cosang, -1.0, 1.0)) >= o.min_ray_angle_deg * kDeg)) return false;
  tr->X = X;
  tr->triangulated = true;
  return true;
}

// Pixel reprojection residual of a point X (in S) in a camera (q_C_S, t_C_S).
struct ReprojectionCost {
  Vec2 x;
  double f;
  template <typename T>
  bool operator()(const T* q, const T* t, const T* X, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_C_S(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t_C_S(t), X_S(X);
    const Eigen::Matrix<T, 3, 1> p = q_C_S * X_S + t_C_S;
    r[0] = T(f) * (p.x() / p.z() - T(x.x()));
    r[1] = T(f) * (p.y() / p.z() - T(x.y()));
    return true;
  }
};

// The scale's gauge: the pair's second camera at unit distance from the first (held at the origin):
// |t_C_S| = |c_S| = 1.
struct UnitBaselineCost {
  template <typename T>
  bool operator()(const T* t, T* r) const {
    using std::sqrt;
    r[0] = T(100.0) * (sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]) - T(1.0));
    return true;
  }
};

std::string Fmt(const char* fmt, double a, double b = 0.0, double c = 0.0) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), fmt, a, b, c);
  return buf;
}

// What every attempt from an initial pair shares.
struct SfmInput {
  const std::vector<SfmFrame>* frames = nullptr;
  std::vector<PointMap> px;  // per frame
  std::vector<size_t> kf;    // keyframe slot -> frame
  Mat3 Kinv;
  double f = 0.0;
  Mat3 R_B_C;
  std::vector<Mat3> R_B0_B;  // the gyroscope's body rotation at each frame (bias 0)
  VisualSfmOptions o;        // the thresholds in the points' pixels

  Mat3 R_Ca_Cb(size_t a, size_t b) const {
    return R_B_C.transpose() * R_B0_B[a].transpose() * R_B0_B[b] * R_B_C;
  }
};

// Steps 2-4 from the keyframe pair (PA, PB): OUT filled, false with OUT->reason when it refuses.
bool SolveFromPair(const SfmInput& in, int pa, int pb, VisualSfmSummary* out) {
  const std::vector<SfmFrame>& frames = *in.frames;
  const std::vector<PointMap>& px = in.px;
  const std::vector<size_t>& kf = in.kf;
  const Mat3& Kinv = in.Kinv;
  const double f = in.f;
  const VisualSfmOptions& o = in.o;
  std::vector<cv::Point2d> p0, p1;
  for (const auto& [id, uv] : px[kf[pb]]) {
    const auto it = px[kf[pa]].find(id);
    if (it == px[kf[pa]].end()) continue;
    const Vec3 a = Kinv * it->second.homogeneous(), b = Kinv * uv.homogeneous();
    p0.emplace_back(a.x() / a.z(), a.y() / a.z());
    p1.emplace_back(b.x() / b.z(), b.y() / b.z());
  }
  const cv::Mat I = cv::Mat::eye(3, 3, CV_64F);
  cv::Mat mask;
  cv::Mat E = cv::findEssentialMat(p0, p1, I, cv::RANSAC, 0.999, o.ransac_px / f, 1000, mask);
  if (E.rows < 3 || E.cols != 3) {
    out->reason = "the essential matrix failed";
    return false;
  }
  cv::Mat Rcv, tcv;
  // The essential matrix's inliers in front of both cameras. recoverPose's default also drops
  // the points further than 50 baselines as "at infinity": at the 8 px of parallax wanted, at f =
  // 906 px, the median point is ~110 baselines away, so on the DM-VIO walk 5-13 of 31-37 points
  // "agreed" and the start waited 2 s longer. Far points count as agreeing here (their depth is
  // the triangulation's business, below).
  constexpr double kFarBaselines = 1e6;
  const int good =
      cv::recoverPose(E.rowRange(0, 3), p0, p1, I, Rcv, tcv, kFarBaselines, mask, cv::noArray());
  if (good < o.min_points) {
    out->reason = Fmt("too few points agree with the essential matrix (%.0f of %.0f, needs %.0f)",
                      good, static_cast<double>(p0.size()), o.min_points);
    return false;
  }
  Mat3 R_C1_C0;
  Vec3 t_C1_C0;
  cv::cv2eigen(Rcv, R_C1_C0);
  cv::cv2eigen(tcv, t_C1_C0);
  {
    const Mat3 gyro = in.R_Ca_Cb(kf[pa], kf[pb]);  // R_C0_C1
    out->rotation_error_deg = LogSO3(gyro * R_C1_C0).norm() / kDeg;
    const double dt = 1e-9 * static_cast<double>(frames[kf[pb]].t_ns - frames[kf[pa]].t_ns);
    const double allowed = o.max_rotation_error_deg + o.max_gyro_bias * dt / kDeg;
    if (!(out->rotation_error_deg <= allowed)) {
      out->reason =
          Fmt("the essential matrix's rotation disagrees with the gyroscope's by %.1f deg "
              "(allowed %.1f deg)",
              out->rotation_error_deg, allowed);
      return false;
    }
  }

  // 3. Tracks over the keyframes; triangulation and PnP.
  std::map<int64_t, Track> tracks;
  for (size_t s = 0; s < kf.size(); ++s)
    for (const auto& [id, uv] : px[kf[s]]) {
      const Vec3 x = Kinv * uv.homogeneous();
      tracks[id].views.emplace_back(static_cast<int>(s), x.head<2>() / x.z());
    }
  std::vector<Pose> T_C_S(kf.size());
  T_C_S[pa] = {true, Rigid3::Identity()};
  T_C_S[pb] = {true, Rigid3(R_C1_C0, t_C1_C0.normalized())};
  const auto triangulate_all = [&] {
    int n = 0;
    for (auto& [id, tr] : tracks)
      if (!tr.triangulated) n += Triangulate(&tr, T_C_S, f, o);
    return n;
  };
  triangulate_all();
  // PnP for keyframe S from the points with a position, started at the pose of keyframe G.
  const auto pnp = [&](int s, int g) {
    std::vector<cv::Point3d> X;
    std::vector<cv::Point2d> x;
    for (const auto& [id, tr] : tracks) {
      if (!tr.triangulated) continue;
      for (const auto& [k, xn] : tr.views)
        if (k == s) {
          X.emplace_back(tr.X.x(), tr.X.y(), tr.X.z());
          x.emplace_back(xn.x(), xn.y());
        }
    }
    if (static_cast<int>(X.size()) < o.min_pnp_points) return false;
    cv::Mat rvec, tvec, R0;
    cv::eigen2cv(Mat3(T_C_S[g].T_C_S.R()), R0);
    cv::Rodrigues(R0, rvec);
    cv::eigen2cv(Vec3(T_C_S[g].T_C_S.translation()), tvec);
    std::vector<int> inliers;
    const bool ok =
        cv::solvePnPRansac(X, x, I, cv::noArray(), rvec, tvec, true, 100, 2.0 * o.ransac_px / f,
                           0.99, inliers, cv::SOLVEPNP_ITERATIVE);
    if (!ok || static_cast<int>(inliers.size()) < o.min_pnp_points) return false;
    cv::Mat Rm;
    cv::Rodrigues(rvec, Rm);
    Mat3 R;
    Vec3 t;
    cv::cv2eigen(Rm, R);
    cv::cv2eigen(tvec, t);
    T_C_S[s] = {true, Rigid3(Orthonormalize(R), t)};
    triangulate_all();
    return true;
  };
  // Outwards from the pair: the keyframes between them, then later ones, then earlier ones, each
  // direction until a keyframe cannot be posed (the tracks broke).
  const int n_kf = static_cast<int>(kf.size());
  for (int s = pa + 1; s < pb; ++s) pnp(s, s - 1 >= pa && T_C_S[s - 1].known ? s - 1 : pa);
  for (int s = pb + 1; s < n_kf && pnp(s, s - 1); ++s) {
  }
  for (int s = pa - 1; s >= 0 && pnp(s, s + 1); --s) {
  }
  std::vector<int> posed;
  for (size_t s = 0; s < kf.size(); ++s)
    if (T_C_S[s].known) posed.push_back(static_cast<int>(s));
  const double span_s =
      1e-9 * static_cast<double>(frames[kf[posed.back()]].t_ns - frames[kf[posed.front()]].t_ns);
  if (!(span_s >= o.min_span_s)) {
    out->reason = Fmt("the keyframes posed span %.2f s only (needs %.2f s): the tracks broke",
                      span_s, o.min_span_s);
    return false;
  }
  if (static_cast<int>(posed.size()) < o.min_keyframes) {
    out->reason =
        Fmt("too few keyframes posed (%.0f of %.0f, needs %.0f)", static_cast<double>(posed.size()),
            static_cast<double>(kf.size()), o.min_keyframes);
    return false;
  }

  // 4. Bundle adjustment.
  std::vector<Eigen::Vector4d> q(kf.size());
  std::vector<Vec3> t(kf.size());
  for (int s : posed) {
    q[s] = T_C_S[s].T_C_S.rotation().coeffs();
    t[s] = T_C_S[s].T_C_S.translation();
  }
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  ceres::EigenQuaternionManifold quat;
  ceres::HuberLoss huber(o.huber_px);
  std::vector<Track*> used;
  for (auto& [id, tr] : tracks) {
    if (!tr.triangulated) continue;
    used.push_back(&tr);
    for (const auto& [k, xn] : tr.views) {
      if (!T_C_S[k].known) continue;
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ReprojectionCost, 2, 4, 3, 3>(
                                   new ReprojectionCost{xn, f}),
                               &huber, q[k].data(), t[k].data(), tr.X.data());
    }
  }
  if (static_cast<int>(used.size()) < o.min_points) {
    out->reason = Fmt("too few points triangulated (%.0f, needs %.0f)",
                      static_cast<double>(used.size()), o.min_points);
    return false;
  }
  for (int s : posed) problem.SetManifold(q[s].data(), &quat);
  problem.SetParameterBlockConstant(q[pa].data());
  problem.SetParameterBlockConstant(t[pa].data());
  problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<UnitBaselineCost, 1, 3>(new UnitBaselineCost), nullptr,
      t[pb].data());
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = o.ba_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  for (int s : posed) T_C_S[s].T_C_S = Rigid3(Quat(q[s]), t[s]);

  double sum = 0.0;
  int n = 0;
  std::vector<double> depths;
  for (Track* tr : used) {
    for (const auto& [k, xn] : tr->views) {
      if (!T_C_S[k].known) continue;
      const double e = ReprojectionPx(T_C_S[k].T_C_S, tr->X, xn, f);
      if (e <= o.max_reprojection_px) {
        sum += e * e;
        ++n;
      }
    }
    out->points_S.push_back(tr->X);
    if (tr->X.z() > 0.0) depths.push_back(tr->X.z());
  }
  out->rms_px = n > 0 ? std::sqrt(sum / n) : 0.0;
  if (!depths.empty()) {
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
    out->median_depth = depths[depths.size() / 2];
  }
  if (!summary.IsSolutionUsable() || !(out->rms_px <= o.max_rms_px)) {
    out->reason =
        Fmt("the bundle adjustment leaves %.2f px RMS (allowed %.2f)", out->rms_px, o.max_rms_px);
    return false;
  }
  for (int s : posed) {
    out->frames.push_back(kf[s]);
    out->T_S_C.push_back(T_C_S[s].T_C_S.Inverse());
  }
  out->success = true;
  return true;
}

}  // namespace

VisualSfmSummary SolveVisualSfm(const std::vector<SfmFrame>& frames,
                                const std::vector<ImuSample>& imu, const Mat3& K,
                                const Rigid3& T_B_C, const VisualSfmOptions& options) {
  VisualSfmSummary out;
  if (frames.size() < 3) {
    out.reason = "too few frames";
    return out;
  }
  SfmInput in;
  in.frames = &frames;
  in.Kinv = K.inverse();
  in.f = K(0, 0);
  in.R_B_C = T_B_C.R();
  // The thresholds on the points' noise, in the points' own pixel noise (the median
  // PointObservation::sigma_scale: 2 for a 1280x720 camera tracked at 640x360).
  std::vector<double> scales;
  for (const SfmFrame& fr : frames)
    for (const PointObservation& p : fr.points) scales.push_back(p.sigma_scale);
  const double noise = std::max(1.0, scales.empty() ? 1.0 : Median(scales));
  VisualSfmOptions& o = in.o;
  o = options;
  o.ransac_px *= noise;
  o.max_reprojection_px *= noise;
  o.max_rms_px *= noise;
  o.huber_px *= noise;
  in.R_B0_B.assign(frames.size(), Mat3::Identity());
  const PreintegrationOptions preint;
  for (size_t k = 1; k < frames.size(); ++k) {
    const int64_t t0 = frames[k - 1].t_ns, t1 = frames[k].t_ns;
    const std::vector<ImuSample> s = ImuSamplesFor(imu, t0, t1);
    Mat3 dR = Mat3::Identity();
    if (!s.empty() && t1 > t0)
      dR = ImuPreintegration(preint, s, t0, t1, Vec3::Zero(), Vec3::Zero())
               .delta_R()
               .toRotationMatrix();
    in.R_B0_B[k] = in.R_B0_B[k - 1] * dR;
  }
  std::vector<PointMap>& px = in.px;
  px.resize(frames.size());
  for (size_t k = 0; k < frames.size(); ++k)
    for (const PointObservation& p : frames[k].points) px[k][p.point_id] = p.uv_undistorted;

  // 1. Keyframes.
  std::vector<size_t>& kf = in.kf;
  kf.push_back(0);
  for (size_t k = 1; k < frames.size(); ++k) {
    int shared = 0;
    const double par =
        MedianParallax(px[kf.back()], px[k], K, in.Kinv, in.R_Ca_Cb(kf.back(), k), &shared);
    const double dt = 1e-9 * static_cast<double>(frames[k].t_ns - frames[kf.back()].t_ns);
    const bool tracks_fading =
        shared < o.keyframe_min_tracked * static_cast<double>(px[kf.back()].size());
    if (par >= o.keyframe_parallax_px || dt >= o.max_keyframe_interval_s || tracks_fading ||
        k + 1 == frames.size())
      kf.push_back(k);
  }
  out.keyframes = static_cast<int>(kf.size());

  // 2. The candidate pairs: keyframes sharing min_points with min_parallax_px, most parallax first.
  struct Candidate {
    double parallax_px;
    int a, b;
  };
  std::vector<Candidate> candidates;
  int most_shared = 0;
  for (size_t i = 0; i < kf.size(); ++i)
    for (size_t j = i + 1; j < kf.size(); ++j) {
      int shared = 0;
      const double par = RotationFreeParallax(px[kf[i]], px[kf[j]], in.Kinv, in.f, &shared);
      most_shared = std::max(most_shared, shared);
      if (shared < o.min_points) break;  // later keyframes share fewer still
      out.max_parallax_px = std::max(out.max_parallax_px, par);
      if (par >= o.min_parallax_px)
        candidates.push_back({par, static_cast<int>(i), static_cast<int>(j)});
    }
  if (candidates.empty()) {
    out.reason = most_shared >= o.min_points
                     ? Fmt("too little parallax: the largest median parallax no rotation "
                           "explains, between two keyframes sharing %.0f points, is %.1f px "
                           "(needs %.0f px)",
                           o.min_points, out.max_parallax_px, o.min_parallax_px)
                     : Fmt("too few points: two keyframes share at most %.0f points (needs "
                           "%.0f)",
                           most_shared, o.min_points);
    return out;
  }
  std::stable_sort(
      candidates.begin(), candidates.end(),
      [](const Candidate& x, const Candidate& y) { return x.parallax_px > y.parallax_px; });
  // 3.-4. From each candidate in turn until one succeeds; a refusal reports the first's reason.
  const size_t tries = std::min<size_t>(candidates.size(), std::max(1, o.max_pairs));
  VisualSfmSummary first;
  for (size_t c = 0; c < tries; ++c) {
    VisualSfmSummary attempt = out;
    attempt.pair_parallax_px = candidates[c].parallax_px;
    attempt.pair_first = kf[candidates[c].a];
    attempt.pair_second = kf[candidates[c].b];
    attempt.pairs_tried = static_cast<int>(c + 1);
    if (SolveFromPair(in, candidates[c].a, candidates[c].b, &attempt)) return attempt;
    if (c == 0) first = std::move(attempt);
  }
  if (tries > 1)
    first.reason +=
        Fmt(" (and the %.0f next pairs by parallax refused too)", static_cast<double>(tries - 1));
  first.pairs_tried = static_cast<int>(tries);
  return first;
}

}  // namespace fsp::backend
