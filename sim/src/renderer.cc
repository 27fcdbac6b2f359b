#include "fsp/sim/renderer.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <numeric>
#include <sstream>
#include <utility>

#include <opencv2/core/utility.hpp>

#include "fsp/common/error.h"
#include "textures.h"

namespace fsp::sim {

bool RenderOptions::Check(std::string* why) const {
  std::ostringstream os;
  if (supersampling < 1 || supersampling > 8)
    os << "supersampling " << supersampling << " is not in 1..8";
  else if (!(ambient >= 0.0 && ambient <= 1.0))
    os << "ambient " << ambient << " is not in [0, 1]";
  else if (motion_blur_samples < 1 || motion_blur_samples > 64)
    os << "motion_blur_samples " << motion_blur_samples << " is not in 1..64";
  else if (!(background >= 0.0 && background <= 1.0))
    os << "background " << background << " is not in [0, 1]";
  else if (!(room_texels_per_m > 0.0 && room_texels_per_m <= 5000.0))
    os << "room_texels_per_m " << room_texels_per_m << " is not in (0, 5000]";
  else if (!(object_texels_per_m > 0.0 && object_texels_per_m <= 5000.0))
    os << "object_texels_per_m " << object_texels_per_m << " is not in (0, 5000]";
  else if (max_texture_side < 16 || max_texture_side > 16384)
    os << "max_texture_side " << max_texture_side << " is not in 16..16384";
  if (why) *why = os.str();
  return os.str().empty();
}

namespace {

constexpr int kTile = 16;        // tile side in pixels (culling granularity)
constexpr double kNearZ = 1e-5;  // quads are clipped to z_C >= this (metres) for culling
constexpr float kRoomDepthBias = 1.0f + 1e-5f;  // room surfaces lose depth ties against objects

struct Texture {
  int w = 0, h = 0;
  float sx = 0.f, sy = 0.f;  // w - 1, h - 1
  std::vector<float> data;

  // Bilinear sample at quad coordinates (a, b) in [0, 1]: column a (w - 1), row (1 - b)(h - 1).
  float Sample(float a, float b) const {
    const float fx = a * sx, fy = (1.f - b) * sy;
    int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
    ix = std::min(std::max(ix, 0), w - 2);
    iy = std::min(std::max(iy, 0), h - 2);
    const float tx = fx - ix, ty = fy - iy;
    const float* p = data.data() + static_cast<size_t>(iy) * w + ix;
    const float top = p[0] + tx * (p[1] - p[0]);
    const float bot = p[w] + tx * (p[w + 1] - p[w]);
    return top + ty * (bot - top);
  }
};

// A quad as rendered, in W: corners origin + a u + b v, unit normal n = u x v / |u x v|, and the
// dual basis du, dv (du.u = 1, du.v = 0, du.n = 0; likewise dv) so that a = du.(X - origin), b =
// dv.(X - origin).
struct Geometry {
  Vec3 origin, u, v, n, du, dv;
  int id = -1;
  bool room = false;
};

Geometry MakeGeometry(const TexturedQuad& q) {
  Geometry g;
  g.origin = q.origin_W;
  g.u = q.axis_u_W;
  g.v = q.axis_v_W;
  if (q.texture == TextureKind::kTag) {
    // The texture spans the black square plus a one-cell white margin: 10/8 of the quad, centred.
    const double m = 0.5 * (double(internal::kTagTotalCells) / internal::kTagBorderCells - 1.0);
    g.origin -= m * (g.u + g.v);
    g.u *= 1.0 + 2.0 * m;
    g.v *= 1.0 + 2.0 * m;
  }
  const Vec3 uxv = g.u.cross(g.v);
  g.n = uxv.normalized();
  g.origin += q.offset_m * g.n;
  // du = (v x n) / ((v x n).u) with (v x n).u = n.(u x v) = |u x v|; dv = (n x u) / |u x v|.
  g.du = g.v.cross(g.n) / uxv.norm();
  g.dv = g.n.cross(g.u) / uxv.norm();
  g.id = q.id;
  g.room = q.id < 0;
  return g;
}

// Per-frame quad in C, single precision for the per-ray loop. Ray X = t r with r = (x, y, 1), so t
// = z_C:
//   den = n.r,  t = c / den with c = n.o  (plane n.X = c),
//   a = t (du.r) - du.o,  b = t (dv.r) - dv.o,
//   shade = ambient + (1 - ambient) |n.r| / |r|   (Lambert-like |cos| between normal and viewing
//   ray).
struct FrameQuad {
  float nx, ny, nz, c;
  float ux, uy, uz, uo;
  float vx, vy, vz, vo;
  float bias;  // depth multiplier for ties: room surfaces slightly behind coplanar objects
  const Texture* tex;
};

struct Vec2d {
  double x, y;
};

}  // namespace

struct Renderer::Impl {
  PinholeRadtan camera;
  RenderOptions options;
  std::vector<TexturedQuad> quads;
  std::vector<Geometry> geometry;
  std::vector<Texture> textures;

  int samples = 1;  // rays per pixel (supersampling^2)
  std::vector<float>
      rays;  // per pixel (row-major) and sample: x, y, 1/|r| (normalised coordinates)
  int tiles_x = 0, tiles_y = 0;
  std::vector<float> tile_box;  // per tile: xmin, xmax, ymin, ymax of its rays (normalised), padded

  void BuildRayTable();
  // One pose's quads in C and, per tile, the indices of the quads that may cover it.
  struct PoseSetup {
    std::vector<FrameQuad> quads;
    std::vector<std::vector<uint16_t>> tiles;
  };
  PoseSetup Setup(const Rigid3& T_W_C) const;
  // Renders into accum (CV_32F, grey in [0, 1]); several poses share each pixel's rays (motion
  // blur).
  void RenderInto(const std::vector<Rigid3>& poses, cv::Mat* accum) const;
};

void Renderer::Impl::BuildRayTable() {
  const int n = options.supersampling;
  samples = n * n;
  // Sample offsets (pixel units, relative to the centre): an n x n grid sheared so that all n^2
  // samples have distinct x and distinct y ("n-rooks"), which resolves near-axis-aligned edges to
  // 1/n^2 px.
  std::vector<Vec2d> offsets;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      offsets.push_back({(i + (j + 0.5) / n) / n - 0.5, (j + (i + 0.5) / n) / n - 0.5});
  const int W = camera.width, H = camera.height;
  rays.resize(static_cast<size_t>(W) * H * samples * 3);
  // Rows are independent: the parallel loop fills the same table as a serial one.
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int py = rows.start; py < rows.end; ++py) {
      size_t k = static_cast<size_t>(py) * W * samples * 3;
      for (int px = 0; px < W; ++px)
        for (const Vec2d& o : offsets) {
          // Distorted pixel -> its ray (x, y, 1) in C (the inverse of the camera's Project).
          const Vec3 ray = camera.Unproject(Vec2(px + o.x, py + o.y));
          rays[k++] = static_cast<float>(ray.x());
          rays[k++] = static_cast<float>(ray.y());
          rays[k++] = static_cast<float>(1.0 / ray.norm());
        }
    }
  });
  tiles_x = (W + kTile - 1) / kTile;
  tiles_y = (H + kTile - 1) / kTile;
  tile_box.assign(static_cast<size_t>(tiles_x) * tiles_y * 4, 0.f);
  for (int ty = 0; ty < tiles_y; ++ty)
    for (int tx = 0; tx < tiles_x; ++tx) {
      float x0 = FLT_MAX, x1 = -FLT_MAX, y0 = FLT_MAX, y1 = -FLT_MAX;
      for (int py = ty * kTile; py < std::min(H, (ty + 1) * kTile); ++py)
        for (int px = tx * kTile; px < std::min(W, (tx + 1) * kTile); ++px)
          for (int s = 0; s < samples; ++s) {
            const float* r = &rays[((static_cast<size_t>(py) * W + px) * samples + s) * 3];
            x0 = std::min(x0, r[0]);
            x1 = std::max(x1, r[0]);
            y0 = std::min(y0, r[1]);
            y1 = std::max(y1, r[1]);
          }
      // Pad for the single-precision ray-quad test near a tile's boundary.
      const float pad =
          1e-5f * (1.f + std::max(std::abs(x0),
                                  std::max(std::abs(x1), std::max(std::abs(y0), std::abs(y1)))));
      float* b = &tile_box[(static_cast<size_t>(ty) * tiles_x + tx) * 4];
      b[0] = x0 - pad;
      b[1] = x1 + pad;
      b[2] = y0 - pad;
      b[3] = y1 + pad;
    }
}

namespace {

// The quad's visible outline in normalised image coordinates: its corners in C clipped to z >=
// kNearZ (Sutherland-Hodgman against one plane), then projected (x/z, y/z). The central projection
// of a convex planar polygon in front of the camera is convex. Empty when the quad is entirely
// behind the camera.
std::vector<Vec2d> ProjectedOutline(const Geometry& g, const Rigid3& T_C_W) {
  const Vec3 P[4] = {T_C_W * g.origin, T_C_W * (g.origin + g.u), T_C_W * (g.origin + g.u + g.v),
                     T_C_W * (g.origin + g.v)};
  std::vector<Vec3> clipped;
  for (int i = 0; i < 4; ++i) {
    const Vec3& a = P[i];
    const Vec3& b = P[(i + 1) % 4];
    const bool ina = a.z() >= kNearZ, inb = b.z() >= kNearZ;
    if (ina) clipped.push_back(a);
    if (ina != inb) {
      const double s = (kNearZ - a.z()) / (b.z() - a.z());
      Vec3 p = a + s * (b - a);
      p.z() = kNearZ;
      clipped.push_back(p);
    }
  }
  std::vector<Vec2d> out;
  out.reserve(clipped.size());
  for (const Vec3& p : clipped) out.push_back({p.x() / p.z(), p.y() / p.z()});
  return out;
}

// Whether the convex polygon (either orientation) may overlap the box [x0, x1] x [y0, y1]:
// separating axis test over the box's axes (bounding boxes) and the polygon's edge normals.
// Conservative.
bool PolygonOverlapsBox(const std::vector<Vec2d>& poly, double orient, double x0, double x1,
                        double y0, double y1) {
  const size_t n = poly.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec2d& p = poly[i];
    const Vec2d& q = poly[(i + 1) % n];
    // Inside is where orient * cross(e, X - p) >= 0; the box is separated when even its most inside
    // corner is outside. cross(e, X - p) = ex (Xy - py) - ey (Xx - px), maximised per coordinate.
    const double ex = orient * (q.x - p.x), ey = orient * (q.y - p.y);
    const double Xy = ex > 0 ? y1 : y0;
    const double Xx = ey > 0 ? x0 : x1;
    if (ex * (Xy - p.y) - ey * (Xx - p.x) < 0.0) return false;
  }
  return true;
}

}  // namespace

Renderer::Impl::PoseSetup Renderer::Impl::Setup(const Rigid3& T_W_C) const {
  const Rigid3 T_C_W = T_W_C.Inverse();
  const Mat3 R_C_W = T_C_W.R();
  PoseSetup out;
  std::vector<FrameQuad>& fq = out.quads;
  std::vector<std::vector<uint16_t>>& tile_quads = out.tiles;
  tile_quads.resize(static_cast<size_t>(tiles_x) * tiles_y);
  for (size_t qi = 0; qi < geometry.size(); ++qi) {
    const Geometry& g = geometry[qi];
    const Vec3 o = T_C_W * g.origin;
    const Vec3 n = R_C_W * g.n, du = R_C_W * g.du, dv = R_C_W * g.dv;
    const double c = n.dot(o);
    if (std::abs(c) < 1e-9) continue;  // plane through the camera centre: seen edge-on
    const std::vector<Vec2d> poly = ProjectedOutline(g, T_C_W);
    if (poly.size() < 3) continue;
    double area2 = 0.0, bx0 = DBL_MAX, bx1 = -DBL_MAX, by0 = DBL_MAX, by1 = -DBL_MAX;
    for (size_t i = 0; i < poly.size(); ++i) {
      const Vec2d& p = poly[i];
      const Vec2d& q = poly[(i + 1) % poly.size()];
      area2 += p.x * q.y - q.x * p.y;
      bx0 = std::min(bx0, p.x);
      bx1 = std::max(bx1, p.x);
      by0 = std::min(by0, p.y);
      by1 = std::max(by1, p.y);
    }
    if (!(std::abs(area2) > 1e-14)) continue;
    const double orient = area2 > 0 ? 1.0 : -1.0;
    const uint16_t index = static_cast<uint16_t>(fq.size());
    bool any = false;
    for (int t = 0; t < tiles_x * tiles_y; ++t) {
      const float* b = &tile_box[static_cast<size_t>(t) * 4];
      if (bx1 < b[0] || bx0 > b[1] || by1 < b[2] || by0 > b[3]) continue;
      if (!PolygonOverlapsBox(poly, orient, b[0], b[1], b[2], b[3])) continue;
      tile_quads[t].push_back(index);
      any = true;
    }
    if (!any) continue;
    FrameQuad f;
    f.nx = static_cast<float>(n.x());
    f.ny = static_cast<float>(n.y());
    f.nz = static_cast<float>(n.z());
    f.c = static_cast<float>(c);
    f.ux = static_cast<float>(du.x());
    f.uy = static_cast<float>(du.y());
    f.uz = static_cast<float>(du.z());
    f.uo = static_cast<float>(du.dot(o));
    f.vx = static_cast<float>(dv.x());
    f.vy = static_cast<float>(dv.y());
    f.vz = static_cast<float>(dv.z());
    f.vo = static_cast<float>(dv.dot(o));
    f.bias = g.room ? kRoomDepthBias : 1.f;
    f.tex = &textures[qi];
    fq.push_back(f);
  }

  return out;
}

void Renderer::Impl::RenderInto(const std::vector<Rigid3>& poses, cv::Mat* accum) const {
  const int W = camera.width, H = camera.height;
  const float ambient = static_cast<float>(options.ambient);
  const float diffuse = 1.f - ambient;
  const float background = static_cast<float>(options.background);
  // Poses share the rays: slot j = 0 .. P S - 1 of a pixel uses sub-pixel sample j mod S and pose
  // (j + rot(px, py)) mod N. P = N / gcd(S, N) passes make P S a multiple of N, so every pose gets
  // the same number of rays in every pixel; the pseudo-random rotation decorrelates pose and
  // sub-pixel offset across neighbouring pixels. Cost: P renders instead of N. With one pose this
  // is plain supersampling.
  const int N = static_cast<int>(poses.size());
  const int S = samples;
  const int P = N / std::gcd(S, N);
  const float inv_slots = 1.f / static_cast<float>(P * S);
  std::vector<PoseSetup> setups;
  setups.reserve(N);
  for (const Rigid3& T_W_C : poses) setups.push_back(Setup(T_W_C));

  std::vector<std::vector<const FrameQuad*>> cands(N);
  for (int ty = 0; ty < tiles_y; ++ty)
    for (int tx = 0; tx < tiles_x; ++tx) {
      const size_t tile = static_cast<size_t>(ty) * tiles_x + tx;
      for (int k = 0; k < N; ++k) {
        cands[k].clear();
        for (uint16_t i : setups[k].tiles[tile]) cands[k].push_back(&setups[k].quads[i]);
      }
      const int px0 = tx * kTile, px1 = std::min(W, px0 + kTile);
      const int py0 = ty * kTile, py1 = std::min(H, py0 + kTile);
      for (int py = py0; py < py1; ++py) {
        float* out = accum->ptr<float>(py);
        for (int px = px0; px < px1; ++px) {
          const float* rays_px = &rays[(static_cast<size_t>(py) * W + px) * S * 3];
          float sum = 0.f;
          // Per-pixel rotation of the pose sequence from an integer hash of (px, py), so that the
          // pose/sub-pixel pairing does not form a visible pattern.
          uint32_t h =
              static_cast<uint32_t>(px) * 0x9E3779B1u ^ static_cast<uint32_t>(py) * 0x85EBCA77u;
          h ^= h >> 15;
          h *= 0x2C1B3C6Du;
          h ^= h >> 12;
          int pose = static_cast<int>(h % static_cast<uint32_t>(N));
          for (int j = 0; j < P * S; ++j) {
            const float* r = rays_px + (j % S) * 3;
            const std::vector<const FrameQuad*>& cand = cands[pose];
            if (++pose == N) pose = 0;
            const int nc = static_cast<int>(cand.size());
            const float x = r[0], y = r[1];
            // Nearest hit along the ray (x, y, 1): smallest biased depth t inside its rectangle.
            float best = FLT_MAX, ba = 0.f, bb = 0.f, bden = 0.f;
            const FrameQuad* hit = nullptr;
            for (int k = 0; k < nc; ++k) {
              const FrameQuad& q = *cand[k];
              const float den = q.nx * x + q.ny * y + q.nz;
              const float t = q.c / den;
              if (!(t > 0.f) || t * q.bias >= best) continue;
              const float a = t * (q.ux * x + q.uy * y + q.uz) - q.uo;
              if (a < 0.f || a > 1.f) continue;
              const float b = t * (q.vx * x + q.vy * y + q.vz) - q.vo;
              if (b < 0.f || b > 1.f) continue;
              best = t * q.bias;
              ba = a;
              bb = b;
              bden = den;
              hit = &q;
            }
            if (hit == nullptr) {
              sum += background;
            } else {
              sum += hit->tex->Sample(ba, bb) * (ambient + diffuse * std::abs(bden) * r[2]);
            }
          }
          out[px] = sum * inv_slots;
        }
      }
    }
}

Renderer::Renderer(const PinholeRadtan& camera, std::vector<TexturedQuad> quads,
                   const RenderOptions& options)
    : impl_(std::make_unique<Impl>()) {
  std::string why;
  FSP_CHECK(camera.Check(&why));
  FSP_CHECK(options.Check(&why));
  FSP_CHECK(quads.size() < 65535);
  impl_->camera = camera;
  impl_->options = options;
  impl_->quads = std::move(quads);
  for (const TexturedQuad& q : impl_->quads) {
    const double area = q.axis_u_W.cross(q.axis_v_W).norm();
    if (!(area > 1e-12) || !q.origin_W.allFinite() || !q.axis_u_W.allFinite() ||
        !q.axis_v_W.allFinite())
      throw InputError("quad " + std::to_string(q.id) + " has zero area or non-finite corners");
    impl_->geometry.push_back(MakeGeometry(q));
    const double density = q.id < 0 ? options.room_texels_per_m : options.object_texels_per_m;
    int w = 0, h = 0;
    internal::TextureSize(q, density, options.max_texture_side, &w, &h);
    const cv::Mat m = internal::MakeTextureFloat(q, w, h);
    Texture t;
    t.w = w;
    t.h = h;
    t.sx = static_cast<float>(w - 1);
    t.sy = static_cast<float>(h - 1);
    t.data.assign(m.ptr<float>(0), m.ptr<float>(0) + static_cast<size_t>(w) * h);
    impl_->textures.push_back(std::move(t));
  }
  impl_->BuildRayTable();
}

Renderer::~Renderer() = default;
Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&&) noexcept = default;

const std::vector<TexturedQuad>& Renderer::quads() const {
  return impl_->quads;
}

cv::Mat Renderer::Render(const Rigid3& T_W_C) const {
  cv::Mat accum(impl_->camera.height, impl_->camera.width, CV_32FC1);
  impl_->RenderInto({T_W_C}, &accum);
  cv::Mat out;
  accum.convertTo(out, CV_8UC1, 255.0);
  return out;
}

cv::Mat Renderer::Render(const Rigid3& T_W_C_open, const Rigid3& T_W_C_close) const {
  const int n = impl_->options.motion_blur_samples;
  std::vector<Rigid3> poses;
  for (int k = 0; k < n; ++k) poses.push_back(Interpolate(T_W_C_open, T_W_C_close, (k + 0.5) / n));
  cv::Mat accum(impl_->camera.height, impl_->camera.width, CV_32FC1);
  impl_->RenderInto(poses, &accum);
  cv::Mat out;
  accum.convertTo(out, CV_8UC1, 255.0);
  return out;
}

bool Renderer::PointVisible(const Rigid3& T_W_C, const Vec3& p_W, int quad_id, double tol_m) const {
  const Vec3 c_W = T_W_C.translation();
  if ((T_W_C.Inverse() * p_W).z() <= 0.0) return false;
  Vec3 p = p_W;
  if (quad_id >= 0) {
    // Nudge a point on the quad's edge towards its centre so that the ray surely hits the quad
    // itself.
    for (const TexturedQuad& q : impl_->quads)
      if (q.id == quad_id) {
        const Vec3 centre = q.origin_W + 0.5 * (q.axis_u_W + q.axis_v_W);
        const Vec3 d = centre - p;
        if (d.norm() > 1e-9) p += 1e-6 * d.normalized();
        break;
      }
  }
  const Vec3 ray = p - c_W;
  const double dist = ray.norm();
  if (!(dist > 0.0)) return false;
  const Vec3 dir = ray / dist;
  for (const Geometry& g : impl_->geometry) {
    if (quad_id >= 0 && g.id == quad_id) continue;
    // Ray c + s dir meets the plane n.(X - o) = 0 at s = n.(o - c) / n.dir.
    const double den = g.n.dot(dir);
    if (std::abs(den) < 1e-12) continue;
    const double s = g.n.dot(g.origin - c_W) / den;
    if (!(s > 0.0) || s >= dist - tol_m) continue;
    const Vec3 rel = c_W + s * dir - g.origin;
    const double a = g.du.dot(rel), b = g.dv.dot(rel);
    if (a >= 0.0 && a <= 1.0 && b >= 0.0 && b <= 1.0) return false;
  }
  return true;
}

}  // namespace fsp::sim
