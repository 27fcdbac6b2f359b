// The default room rendered in the test process for the PointTracker tests: frames of
// assets/scenes/default_room.yaml exactly as `fsp render` makes them (the scene's renderer, lens
// and pixel noise; frame k at k / 20 s), the camera's ground-truth poses, and the scene point a
// pixel sees (a ray cast onto the room's surfaces and objects).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/geometry.h"
#include "fsp/sim/renderer.h"
#include "fsp/sim/scene.h"
#include "fsp/sim/sequence_writer.h"

namespace fsp::test {

struct RoomFrames {
  sim::Scene scene;
  std::vector<sim::TexturedQuad> quads;
  std::vector<int64_t> t_ns;
  std::vector<Rigid3> T_W_C;
  std::vector<cv::Mat> images;  // CV_8UC1, distorted as rendered

  // The camera's rotation from frame k - 1 to frame k (what a perfect gyroscope gives).
  Mat3 R_Cprev_Ccur(size_t k) const { return T_W_C[k - 1].R().transpose() * T_W_C[k].R(); }

  // The nearest scene point (room surface or object) on the ray of undistorted pixel UV in frame
  // K; false when the ray hits nothing.
  bool SceneAt(size_t k, const Vec2& uv, Vec3* p_W) const {
    const PinholeRadtan& cam = scene.camera;
    const Vec3 d_C((uv.x() - cam.cx) / cam.fx, (uv.y() - cam.cy) / cam.fy, 1.0);
    const Vec3 c = T_W_C[k].translation(), d = T_W_C[k].R() * d_C;
    double best = std::numeric_limits<double>::infinity();
    for (const sim::TexturedQuad& q : quads) {
      const Vec3 n = q.axis_u_W.cross(q.axis_v_W);
      const double den = n.dot(d);
      if (std::abs(den) < 1e-12) continue;
      const double s = n.dot(q.origin_W - c) / den;
      if (!(s > 1e-6) || s >= best) continue;
      const Vec3 r = c + s * d - q.origin_W;
      const double a = r.dot(q.axis_u_W) / q.axis_u_W.squaredNorm();
      const double b = r.dot(q.axis_v_W) / q.axis_v_W.squaredNorm();
      if (a < -1e-9 || a > 1.0 + 1e-9 || b < -1e-9 || b > 1.0 + 1e-9) continue;
      best = s;
    }
    if (!std::isfinite(best)) return false;
    *p_W = c + best * d;
    return true;
  }
};

// Frames FIRST .. FIRST + COUNT - 1 of the default room (20 Hz), rendered on two threads.
inline RoomFrames RenderRoom(int first, int count) {
  RoomFrames r;
  r.scene = sim::LoadScene(std::string(FSP_SOURCE_DIR) + "/assets/scenes/default_room.yaml");
  r.quads = sim::SceneQuads(r.scene);
  const sim::Renderer renderer(r.scene.camera, r.quads, r.scene.render);
  for (int i = 0; i < count; ++i) {
    const int k = first + i;
    r.t_ns.push_back(static_cast<int64_t>(std::llround(k * 1e9 / r.scene.camera_rate_hz)));
    r.T_W_C.push_back(r.scene.trajectory.Pose(r.t_ns.back() * 1e-9) * r.scene.T_B_C);
  }
  r.images.resize(count);
  auto work = [&](int from) {
    for (int i = from; i < count; i += 2) {
      r.images[i] = renderer.Render(r.T_W_C[i]);
      sim::AddPixelNoise(r.scene.pixel_sigma, r.scene.seed, first + i, &r.images[i]);
    }
  };
  std::thread other(work, 1);
  work(0);
  other.join();
  return r;
}

}  // namespace fsp::test
