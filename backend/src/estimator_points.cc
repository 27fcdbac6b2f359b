// Point features in the window (backend/README.md, "Points"; PointOptions): tracks of keyframe
// views, their entry (parallax, triangulation), their factors, the outliers after a solve, and the
// re-anchoring when an anchor leaves the window. Points are not in the global step, the
// marginalisation prior or the map.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include <Eigen/SVD>

#include "estimator_impl.h"
#include "fsp/backend/point_factor.h"

namespace fsp::backend {

bool PointOptions::Check(std::string* why) const {
  std::ostringstream os;
  std::string sub;
  if (!(sigma_px > 0.0))
    os << "sigma_px must be > 0";
  else if (!robust.Check(&sub))
    os << "robust: " << sub;
  else if (max_points < 0 || min_views < 2)
    os << "max_points must be >= 0, min_views >= 2";
  else if (!(min_parallax_deg >= 0.0))
    os << "min_parallax_deg must be >= 0";
  else if (!(min_depth_m > 0.0) || !(max_depth_m > min_depth_m))
    os << "need 0 < min_depth_m < max_depth_m";
  else if (!(max_triangulation_px > 0.0) || !(outlier_px > 0.0))
    os << "max_triangulation_px and outlier_px must be > 0";
  else if (!(global_sigma_m > 0.0) || !(global_sigma_per_m >= 0.0) || !(global_sigma_deg > 0.0))
    os << "need global_sigma_m > 0, global_sigma_per_m >= 0, global_sigma_deg > 0";
  else if (object_probation_views < 0 || !(object_gate_px > 0.0))
    os << "object_probation_views must be >= 0, object_gate_px > 0";
  if (why) *why = os.str();
  return os.str().empty();
}

namespace {

// Normalised image coordinates (x, y, 1) of an undistorted pixel.
Vec3 Bearing(const Mat3& K, const Vec2& uv) {
  const Vec3 b = K.inverse() * Vec3(uv.x(), uv.y(), 1.0);
  return b / b.z();
}

}  // namespace

void Estimator::Impl::AddPointViews(Keyframe* kf) {
  for (const PointObservation& p : kf->points) {
    PointTrack& t = point_tracks[p.point_id];
    if (t.views.empty()) t.sigma_scale = p.sigma_scale;
    t.views.push_back({kf, p.uv_undistorted});
    ++t.keyframes_seen;
  }
  // Candidates: seen now, by enough keyframes, never in before; longest-tracked first, until the
  // keyframe sees max_points live ones (points out of view stay live until their anchor leaves:
  // counted over the window, they would keep a new view's points out after a turn).
  const PointOptions& o = options.points;
  int live = 0;
  std::vector<std::pair<int, int64_t>> candidates;  // (-views, id)
  for (const auto& [id, t] : point_tracks) {
    if (t.live && t.views.back().kf == kf) ++live;
    if (!t.live && !t.dead && t.views.back().kf == kf &&
        static_cast<int>(t.views.size()) >= o.min_views)
      candidates.emplace_back(-static_cast<int>(t.views.size()), id);
  }
  std::sort(candidates.begin(), candidates.end());
  for (const auto& [minus_views, id] : candidates) {
    if (live >= o.max_points) break;
    PointTrack& t = point_tracks[id];
    if (!TriangulatePoint(&t)) continue;
    t.live = t.used = true;
    ++live;
    ++summary.points_used;
  }
  kf->sees_points =
      std::any_of(kf->points.begin(), kf->points.end(), [&](const PointObservation& p) {
        auto it = point_tracks.find(p.point_id);
        return it != point_tracks.end() && it->second.live;
      });
}

bool Estimator::Impl::TriangulatePoint(PointTrack* t) const {
  const PointOptions& o = options.points;
  const PointTrack::View& first = t->views.front();
  const PointTrack::View& last = t->views.back();
  const Rigid3 T_W_F = CameraPose(*first.kf);
  // Parallax: the angle between the first and the newest ray in W (the rotation between the views
  // removed by expressing both in W).
  const Vec3 a = T_W_F.rotation() * Bearing(K, first.uv).normalized();
  const Vec3 b = CameraPose(*last.kf).rotation() * Bearing(K, last.uv).normalized();
  const double parallax = std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
  if (parallax < o.min_parallax_deg) return false;
  // Linear triangulation (DLT) over every view: x (P_3 X) − P_1 X = 0, y (P_3 X) − P_2 X = 0.
  const int n = static_cast<int>(t->views.size());
  Eigen::MatrixXd A(2 * n, 4);
  std::vector<Rigid3> T_C_W(n);
  for (int i = 0; i < n; ++i) {
    T_C_W[i] = CameraPose(*t->views[i].kf).Inverse();
    Eigen::Matrix<double, 3, 4> P;
    P.leftCols<3>() = T_C_W[i].R();
    P.col(3) = T_C_W[i].translation();
    const Vec3 x = Bearing(K, t->views[i].uv);
    A.row(2 * i) = x.x() * P.row(2) - P.row(0);
    A.row(2 * i + 1) = x.y() * P.row(2) - P.row(1);
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (!(std::abs(X(3)) > 1e-12)) return false;
  const Vec3 p_W = X.head<3>() / X(3);
  if (!p_W.allFinite()) return false;
  for (int i = 0; i < n; ++i) {
    const Vec3 p_C = T_C_W[i] * p_W;
    if (!(p_C.z() > o.min_depth_m)) return false;
    const Vec3 uv = K * p_C;
    if ((uv.head<2>() / uv.z() - t->views[i].uv).norm() > o.max_triangulation_px) return false;
  }
  const double z_F = (T_C_W[0] * p_W).z();
  if (z_F > o.max_depth_m) return false;
  t->anchor = first.kf;
  t->bearing_F = Bearing(K, first.uv);
  t->rho = 1.0 / z_F;
  return true;
}

FspFactorOptions Estimator::Impl::PointFactorOptions(const PointTrack& t) const {
  FspFactorOptions fo = options.factor;
  fo.sigma_px = PointSigmaPx(t.sigma_scale);
  return fo;
}

void Estimator::Impl::AddPointFactors(ceres::Problem* problem) {
  const PointOptions& o = options.points;
  for (auto& [id, t] : point_tracks) {
    if (!t.live) continue;
    const FspFactorOptions fo = PointFactorOptions(t);
    const Rigid3 T_W_F = CameraPose(*t.anchor);
    bool added = false;
    for (const PointTrack::View& v : t.views) {
      if (v.kf == t.anchor) continue;  // independent of ρ and of the poses
      if (!(PredictPoint(K, CameraPose(*v.kf), T_W_F, t.bearing_F, t.rho).h_z > fo.min_h_z))
        continue;
      problem->AddResidualBlock(new PointFactor(v.uv, t.bearing_F, K, T_B_C, fo),
                                MakeRobustLoss(o.robust, 2).release(), v.kf->state.pose,
                                t.anchor->state.pose, &t.rho);
      added = true;
    }
    if (added) {
      problem->SetParameterLowerBound(&t.rho, 0, 1.0 / o.max_depth_m);
      problem->SetParameterUpperBound(&t.rho, 0, 1.0 / o.min_depth_m);
    }
  }
}

void Estimator::Impl::AddPointFactorsOf(ceres::Problem* problem, Keyframe* kf) {
  const PointOptions& o = options.points;
  for (const PointObservation& p : kf->points) {
    auto it = point_tracks.find(p.point_id);
    if (it == point_tracks.end() || !it->second.live) continue;
    PointTrack& t = it->second;
    if (t.anchor == kf) continue;
    const FspFactorOptions fo = PointFactorOptions(t);
    const Rigid3 T_W_F = CameraPose(*t.anchor);
    if (!(PredictPoint(K, CameraPose(*kf), T_W_F, t.bearing_F, t.rho).h_z > fo.min_h_z)) continue;
    problem->AddParameterBlock(t.anchor->state.pose, kPoseSize, &pose_manifold);
    problem->AddResidualBlock(new PointFactor(p.uv_undistorted, t.bearing_F, K, T_B_C, fo),
                              MakeRobustLoss(o.robust, 2).release(), kf->state.pose,
                              t.anchor->state.pose, &t.rho);
  }
}

std::vector<ResidualBlockInput> Estimator::Impl::AddPointFactorsOf(
    Keyframe* old, std::vector<std::unique_ptr<ceres::CostFunction>>* costs,
    std::vector<std::unique_ptr<ceres::LossFunction>>* losses) {
  const PointOptions& o = options.points;
  std::vector<ResidualBlockInput> inputs;
  const Rigid3 T_W_F = CameraPose(*old);
  for (auto& [id, t] : point_tracks) {
    if (!t.live || t.anchor != old) continue;
    const FspFactorOptions fo = PointFactorOptions(t);
    for (const PointTrack::View& v : t.views) {
      if (v.kf == old) continue;
      if (!(PredictPoint(K, CameraPose(*v.kf), T_W_F, t.bearing_F, t.rho).h_z > fo.min_h_z))
        continue;
      costs->emplace_back(new PointFactor(v.uv, t.bearing_F, K, T_B_C, fo));
      losses->push_back(MakeRobustLoss(o.robust, 2));
      inputs.push_back(
          {costs->back().get(), losses->back().get(), {v.kf->state.pose, old->state.pose, &t.rho}});
    }
  }
  return inputs;
}

void Estimator::Impl::RemovePointOutliers() {
  const PointOptions& o = options.points;
  const double rho_lo = 1.0 / o.max_depth_m, rho_hi = 1.0 / o.min_depth_m;
  for (auto& [id, t] : point_tracks) {
    if (!t.live) continue;
    bool bad = !(t.rho > rho_lo * (1.0 + 1e-6) && t.rho < rho_hi * (1.0 - 1e-6));
    const Rigid3 T_W_F = CameraPose(*t.anchor);
    for (size_t i = 0; i < t.views.size() && !bad; ++i) {
      const PointPrediction p =
          PredictPoint(K, CameraPose(*t.views[i].kf), T_W_F, t.bearing_F, t.rho);
      bad = !p.in_front || (p.uv - t.views[i].uv).norm() > o.outlier_px;
    }
    if (!bad) continue;
    StopPoint(&t);
    ++summary.points_rejected;
  }
}

void Estimator::Impl::ReanchorPointsOf(Keyframe* old) {
  const PointOptions& o = options.points;
  for (auto it = point_tracks.begin(); it != point_tracks.end();) {
    PointTrack& t = it->second;
    const bool anchored = t.live && t.anchor == old;
    const Vec3 p_W = anchored ? CameraPose(*old) * (t.bearing_F / t.rho) : Vec3::Zero();
    t.views.erase(std::remove_if(t.views.begin(), t.views.end(),
                                 [old](const PointTrack::View& v) { return v.kf == old; }),
                  t.views.end());
    if (anchored) {
      // Into the next keyframe that saw it, along that view's bearing (VINS-Mono's
      // shift of the depth to the next frame); a single view left constrains nothing.
      bool ok = o.reanchor && t.views.size() >= 2;
      if (ok) {
        const PointTrack::View& next = t.views.front();
        const double z = (CameraPose(*next.kf).Inverse() * p_W).z();
        ok = z > o.min_depth_m && z < o.max_depth_m;
        if (ok) {
          t.anchor = next.kf;
          t.bearing_F = Bearing(K, next.uv);
          t.rho = 1.0 / z;
          ++summary.points_reanchored;
        }
      }
      if (!ok) {
        StopPoint(&t);
        ++summary.points_dropped;
        // Its views so far are in the prior now; still tracked, it enters again as a new landmark
        // from its next keyframes' views (as Basalt's landmarks when their host leaves).
        t.views.clear();
      }
    }
    if (t.views.empty()) {
      StopPoint(&t);
      it = point_tracks.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace fsp::backend
