// Ray-casting renderer for scenes made of textured rectangles (room surfaces and objects).
//
// Every pixel's ray is intersected with every quad (no polygon clipping, so a quad partly behind the
// camera renders correctly); the nearest hit is shaded by sampling its procedural texture bilinearly.
// Supersampling (several rays per pixel) suppresses aliasing; motion blur averages renders along the
// exposure; distortion maps each output pixel through the camera's radial-tangential model.
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
  kWall, kFloor, kCeiling,       // room surfaces
  kWood,                         // doors, cabinets: wood grain with a dark frame
  kGlass,                        // windows: bright pane with frame and mullions
  kPoster,                       // posters/paintings: shapes and text on a light background
  kCabinet,                      // cabinet front: panels and handle
  kTag,                          // AprilTag tag36h11 code (tag_id), white border included
  kPlain                         // uniform bright face with a dark border (tests: high contrast)
};

// A planar rectangle: points origin_W + a * axis_u_W + b * axis_v_W for a, b in [0, 1].
// For objects origin_W is corner s1, axis_u_W = s2 - s1 (width), axis_v_W = s4 - s1 (height).
struct TexturedQuad {
  int id = -1;                   // object id; -1 for room surfaces
  Vec3 origin_W = Vec3::Zero();
  Vec3 axis_u_W = Vec3::UnitX();
  Vec3 axis_v_W = Vec3::UnitY();
  TextureKind texture = TextureKind::kPlain;
  int tag_id = 0;                // for kTag: which tag36h11 code
  uint32_t seed = 0;             // varies the procedural texture
  double offset_m = 0.0;         // objects sit this far in front of their wall (avoids z-fighting)
};

struct RenderOptions {
  int supersampling = 2;         // rays per pixel per axis (2 -> 4 rays). 1 is fastest, aliased.
  double ambient = 0.25;         // light model: ambient + (1 - ambient) * |cos(normal, ray)|
  int motion_blur_samples = 1;   // >1: average this many poses over the exposure (Render with 2 poses)
  bool Check(std::string* why) const;
};

class Renderer {
 public:
  // Textures are generated once here (deterministically from each quad's seed).
  Renderer(const PinholeRadtan& camera, std::vector<TexturedQuad> quads, const RenderOptions& options);
  ~Renderer();
  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;

  // 8-bit grey image (CV_8UC1, camera.height x camera.width), camera pose T_W_C. Distortion from the
  // camera model is applied. Deterministic; no noise (the caller adds pixel noise with its own seed).
  cv::Mat Render(const Rigid3& T_W_C) const;
  // Motion blur: averages options.motion_blur_samples renders interpolated between the two poses
  // (shutter open, shutter close).
  cv::Mat Render(const Rigid3& T_W_C_open, const Rigid3& T_W_C_close) const;

  // Id of the first quad hit by the ray from the camera centre through point p_W, and whether p_W
  // itself is that first hit (within tol_m): used for the ground truth's occlusion flag.
  bool PointVisible(const Rigid3& T_W_C, const Vec3& p_W, int quad_id, double tol_m = 1e-3) const;

  const std::vector<TexturedQuad>& quads() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The texture image a quad is painted with (for tests and the top-view picture): CV_8UC1 of
// width_px x height_px, row 0 at the quad's top (v = 1) edge.
cv::Mat MakeTexture(const TexturedQuad& quad, int width_px, int height_px);

}  // namespace fsp::sim
