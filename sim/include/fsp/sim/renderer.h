// Ray-casting renderer for scenes made of textured rectangles (room surfaces and objects).
//
// Every pixel's ray is intersected with every quad (no polygon clipping, so a quad partly behind
// the camera renders correctly); the nearest hit is shaded by sampling its procedural texture
// bilinearly. Supersampling (several rays per pixel) suppresses aliasing; motion blur averages
// renders along the exposure; distortion maps each output pixel through the camera's
// radial-tangential model.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/common/camera.h"
#include "fsp/common/geometry.h"

namespace fsp::sim {

enum class TextureKind {
  kWall,
  kFloor,
  kCeiling,  // room surfaces
  kWood,     // doors, cabinets: wood grain with a dark frame
  kGlass,    // windows: bright pane with frame and mullions
  kPoster,   // posters/paintings: shapes and text on a light background
  kCabinet,  // cabinet front: panels and handle
  kTag,      // AprilTag tag36h11 code (tag_id); see TexturedQuad for the geometry
  kPlain,    // uniform bright face with a dark border (tests: high contrast)
  kPaint     // painted wall: the plaster of kWall at a fifth of its contrast (few point features)
};

// A planar rectangle: points origin_W + a * axis_u_W + b * axis_v_W for a, b in [0, 1].
// For objects origin_W is corner s1, axis_u_W = s2 - s1 (width), axis_v_W = s4 - s1 (height).
// Texture orientation: the point (a, b) shows texture column a * (W - 1), row (1 - b) * (H - 1), so
// row 0 is the v = 1 edge (the top of an upright object seen from its front, normal axis_u x
// axis_v). Quads are two-sided. An object may lie exactly in its wall's plane: where an object (id
// >= 0) and a room surface (id < 0) are hit at the same depth (relative 1e-5), the object wins, so
// no offset is needed. kTag: the quad is the tag's black square (its outer edge), so the quad's
// corners are the corners that AprilTag reports (after its -0.5 px shift); the renderer adds the
// code's white margin (one cell, 1/8 of the side) outside the quad, and that margin also hides what
// lies behind it.
struct TexturedQuad {
  int id = -1;  // object id; -1 for room surfaces
  Vec3 origin_W = Vec3::Zero();
  Vec3 axis_u_W = Vec3::UnitX();
  Vec3 axis_v_W = Vec3::UnitY();
  TextureKind texture = TextureKind::kPlain;
  int tag_id = 0;         // for kTag: which tag36h11 code
  uint32_t seed = 0;      // varies the procedural texture
  double offset_m = 0.0;  // rendered this far along the unit normal axis_u x axis_v (metres);
                          // 0 keeps the image on the corners given (ground truth = these corners)
};

struct RenderOptions {
  int supersampling = 2;        // rays per pixel per axis (2 -> 4 rays). 1 is fastest, aliased.
  double ambient = 0.25;        // light model: ambient + (1 - ambient) * |cos(normal, ray)|
  int motion_blur_samples = 1;  // poses over the exposure (Render with 2 poses); more: smoother
                                // blur, cost N / gcd(supersampling^2, N) renders
  double background = 0.0;      // grey level in [0, 1] where a ray hits nothing
  double room_texels_per_m =
      200.0;  // texture resolution of room surfaces (id < 0): memory ~ area * d^2
              // floats; 200/m is ~1 texel per pixel at 2 m with fx ~ 460
  double object_texels_per_m = 500.0;  // texture resolution of objects; ~1 texel per pixel at 1 m
  int max_texture_side = 4096;  // cap on a texture's width and height in texels (memory bound)
  bool Check(std::string* why) const;
};

class Renderer {
 public:
  // Textures are generated once here (deterministically from each quad's seed).
  Renderer(const PinholeRadtan& camera, std::vector<TexturedQuad> quads,
           const RenderOptions& options);
  ~Renderer();
  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;

  // 8-bit grey image (CV_8UC1, camera.height x camera.width), camera pose T_W_C. Distortion from
  // the camera model is applied. Deterministic; no noise (the caller adds pixel noise with its own
  // seed).
  cv::Mat Render(const Rigid3& T_W_C) const;
  // Motion blur over the exposure (shutter open, shutter close): N = options.motion_blur_samples
  // poses at alpha = (k + 0.5) / N, k = 0..N-1 (N = 1: the midpoint). The poses share each pixel's
  // rays (every pose gets the same number of the pixel's sub-pixel rays), so N poses cost N /
  // gcd(S, N) renders with S = supersampling^2 rays per pixel: N = 4 at supersampling 2 costs one
  // render. A still camera gives exactly Render(T_W_C).
  cv::Mat Render(const Rigid3& T_W_C_open, const Rigid3& T_W_C_close) const;

  // True when nothing hides p_W (a point on quad quad_id, e.g. a corner) from the camera centre: no
  // quad other than quad_id is hit by the segment camera -> p_W closer than |p_W - c| - tol_m. A
  // point on the quad's edge is nudged 1e-6 m towards the quad's centre first, so corners are
  // decided robustly. False when p_W is not in front of the camera (z_C <= 0). Ground truth's
  // occlusion flag. Image bounds are not checked here.
  bool PointVisible(const Rigid3& T_W_C, const Vec3& p_W, int quad_id, double tol_m = 1e-3) const;

  const std::vector<TexturedQuad>& quads() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The texture image a quad is painted with (for tests and the top-view picture): CV_8UC1 of
// width_px x height_px, row 0 at the quad's top (v = 1) edge. For kTag the image spans the tag with
// its white margin (10 x 10 cells for tag36h11), i.e. 1.25 times the quad on each axis.
cv::Mat MakeTexture(const TexturedQuad& quad, int width_px, int height_px);

}  // namespace fsp::sim
