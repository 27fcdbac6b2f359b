#include "fsp/backend/motion_init.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <sstream>

#include <Eigen/Dense>

#include "fsp/backend/vi_alignment.h"

namespace fsp::backend {

bool MotionInitOptions::Check(std::string* why) const {
  std::ostringstream os;
  if (!(window_s > 0.0) || !(max_wait_s >= window_s))
    os << "window_s must be > 0 and max_wait_s >= window_s";
  else if (min_views < 3 || !(min_view_spacing_s >= 0.0))
    os << "min_views must be >= 3, min_view_spacing_s >= 0";
  else if (!(max_rotation_error_deg > 0.0) || !(max_gravity_error > 0.0))
    os << "max_rotation_error_deg and max_gravity_error must be > 0";
  else if (!(min_width_m > 0.0) || !(max_width_m > min_width_m))
    os << "need 0 < min_width_m < max_width_m";
  if (why) *why = os.str();
  return os.str().empty();
}

namespace {

// One view of the reference object: the body rotation R_O_B and the camera position at unit
// width ĉ (metric position s ĉ).
struct View {
  size_t frame = 0;
  int64_t t_ns = 0;
  Mat3 R_O_B;
  Vec3 p_C_O;  // s1 in the camera at unit width
  Vec3 c_hat;
  double area_px = 0.0;
};

double QuadArea(const Corners& c) {
  double a = 0.0;
  for (int j = 0; j < 4; ++j) {
    const Vec2& p = c[j];
    const Vec2& q = c[(j + 1) % 4];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return std::abs(0.5 * a);
}

std::vector<AlignmentView> ForAlignment(const std::vector<View>& views) {
  std::vector<AlignmentView> out;
  for (const View& v : views) out.push_back({v.R_O_B, v.c_hat});
  return out;
}

}  // namespace

MotionInitSummary InitializeInMotion(const std::vector<BufferedFrame>& frames,
                                     const std::vector<ImuSample>& imu, const Mat3& K,
                                     const Rigid3& T_B_C, const PreintegrationOptions& preint,
                                     const SingleViewInitOptions& single_view,
                                     const MotionInitOptions& options) {
  MotionInitSummary out;
  // 1. The reference object and its views.
  std::map<int, int> count;
  for (const auto& [t_ns, obs] : frames)
    for (const ObjectObservation& o : obs) ++count[o.object_id];
  int id = -1, best = 0;
  for (const auto& [i, c] : count)
    if (c > best) std::tie(id, best) = std::pair<int, int>{i, c};
  if (best < options.min_views) {
    char why[160];
    std::snprintf(why, sizeof(why),
                  "no object seen in %d frames of the first %g s (the most: %d frames)",
                  options.min_views, options.window_s, best);
    out.reason = why;
    return out;
  }
  const Mat3 R_C_B = T_B_C.rotation().toRotationMatrix().transpose();
  std::vector<View> views;
  int64_t last_t = 0;
  const int64_t spacing_ns = static_cast<int64_t>(options.min_view_spacing_s * 1e9);
  for (size_t f = 0; f < frames.size(); ++f)
    for (const ObjectObservation& o : frames[f].second) {
      if (o.object_id != id || (!views.empty() && frames[f].first - last_t < spacing_ns)) continue;
      const SingleViewInitSummary sv =
          InitializeFspSingleView(o.corners, K, o.object_class, single_view);
      if (!sv.success()) continue;
      const Mat3 R_C_O = sv.landmark.R_F_O();
      const Vec3 p_C_O = sv.landmark.Ray() / sv.landmark.Wbar();  // s1 at unit width
      View v;
      v.frame = f;
      v.t_ns = frames[f].first;
      v.R_O_B = R_C_O.transpose() * R_C_B;
      v.p_C_O = p_C_O;
      v.c_hat = -R_C_O.transpose() * p_C_O;
      v.area_px = QuadArea(o.corners);
      views.push_back(v);
      last_t = v.t_ns;
    }
  if (views.size() < 4) {
    out.reason = "the reference object's single-view poses failed";
    return out;
  }
  // Rotations against the gyroscope (bias 0 over the short window), from the largest view.
  const auto integrate = [&](int64_t t0, int64_t t1, const Vec3& bg) {
    return std::make_unique<ImuPreintegration>(preint, ImuSamplesFor(imu, t0, t1), t0, t1, bg,
                                               Vec3::Zero());
  };
  const auto largest = [&views] {
    size_t a = 0;
    for (size_t k = 1; k < views.size(); ++k)
      if (views[k].area_px > views[a].area_px) a = k;
    return a;
  };
  {
    const size_t a = largest();
    const double max_rad = options.max_rotation_error_deg * (M_PI / 180.0);
    std::vector<View> kept;
    for (size_t k = 0; k < views.size(); ++k) {
      Mat3 predicted = views[a].R_O_B;
      if (k != a) {
        const int64_t t0 = std::min(views[a].t_ns, views[k].t_ns);
        const int64_t t1 = std::max(views[a].t_ns, views[k].t_ns);
        const Mat3 dR = integrate(t0, t1, Vec3::Zero())->delta_R().toRotationMatrix();
        predicted = k > a ? Mat3(views[a].R_O_B * dR) : Mat3(views[a].R_O_B * dR.transpose());
      }
      if (LogSO3(predicted.transpose() * views[k].R_O_B).norm() <= max_rad)
        kept.push_back(views[k]);
    }
    views = std::move(kept);
  }
  if (views.size() < 4) {
    out.reason = "the reference object's poses disagree with the gyroscope";
    return out;
  }
  // 2. The gyroscope bias is left at 0 (the estimator's prior, prior_gyro_bias_sigma, refines it):
  // single-view rotations disagree with the gyroscope by 3-8 deg on a rendered 1.4 m window at
  // 4.6 m (1 px noise), which made a bias fitted to them 0.09 rad/s wrong.
  std::vector<std::unique_ptr<ImuPreintegration>> pre;
  for (size_t k = 0; k + 1 < views.size(); ++k)
    pre.push_back(integrate(views[k].t_ns, views[k + 1].t_ns, Vec3::Zero()));
  // The rotations from the largest view through the gyroscope: a small rectangle's orientation
  // from one view is uncertain by degrees, which moves the camera position in O by centimetres per
  // metre of depth, more than the camera moves between views; the gyroscope's relative rotations
  // are far better, and the position of the rectangle in the camera (p_C_O) is well determined.
  {
    const size_t a = largest();
    const Mat3 R_B_C = T_B_C.rotation().toRotationMatrix();
    for (size_t k = a + 1; k < views.size(); ++k)
      views[k].R_O_B = views[k - 1].R_O_B * pre[k - 1]->delta_R().toRotationMatrix();
    for (size_t k = a; k-- > 0;)
      views[k].R_O_B = views[k + 1].R_O_B * pre[k]->delta_R().toRotationMatrix().transpose();
    for (View& v : views) v.c_hat = -(v.R_O_B * R_B_C) * v.p_C_O;
  }
  // 3. Velocities, gravity, scale; then gravity's magnitude fixed.
  const Vec3 p_B_C = T_B_C.translation();
  const std::vector<AlignmentView> aviews = ForAlignment(views);
  Alignment al = AlignVisualInertial(aviews, pre, p_B_C, nullptr, preint.gravity);
  out.gravity_error = std::abs(al.g.norm() - preint.gravity);
  if (!(al.s > 0.0) || !std::isfinite(al.s) || out.gravity_error > options.max_gravity_error) {
    char why[200];
    std::snprintf(why, sizeof(why),
                  "in motion: the alignment is implausible (scale %.3g, |g| %.2f m/s^2): too "
                  "little acceleration, or inconsistent data",
                  al.s, al.g.norm());
    out.reason = why;
    return out;
  }
  for (int it = 0; it < 4; ++it) {
    const Vec3 dir = al.g.normalized();
    al = AlignVisualInertial(aviews, pre, p_B_C, &dir, preint.gravity);
  }
  if (!(al.s > 0.0) || !std::isfinite(al.s)) {
    out.reason = "in motion: the scale is not positive after fixing gravity's magnitude";
    return out;
  }
  if (al.s < options.min_width_m || al.s > options.max_width_m) {
    char why[200];
    std::snprintf(why, sizeof(why),
                  "in motion: object %d would be %.3g m wide, outside the plausible %.2g-%.2g m "
                  "(too little acceleration, or a wrong track)",
                  id, al.s, options.min_width_m, options.max_width_m);
    out.reason = why;
    return out;
  }
  // 4. The world frame: z up, p = 0 at the first view.
  const Quat q_W_O = Quat::FromTwoVectors(al.g.normalized(), -Vec3::UnitZ());
  out.success = true;
  out.first = views.front().frame;
  out.T_W_B = Rigid3(q_W_O * Quat(views.front().R_O_B), Vec3::Zero());
  out.v_W = q_W_O * al.v.front();
  out.object_id = id;
  out.views = static_cast<int>(views.size());
  out.width = al.s;
  return out;
}

}  // namespace fsp::backend
