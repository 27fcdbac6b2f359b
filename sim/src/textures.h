// Procedural textures for the renderer (internal to fsp_sim).
//
// Every texture is a pure function of the quad (kind, seed, physical size, tag id): no global
// state, so the same scene gives the same pixels. Values are grey levels in [0, 1]. Texel (col i,
// row j) shows the quad point a = i / (W - 1), b = 1 - j / (H - 1) (row 0 at the top edge, v = 1),
// and each texel is the box-filtered average of the procedural pattern over its footprint, so a
// sharp boundary that falls on a texel centre gets exactly the mid value and bilinear sampling
// keeps the boundary in place.
#pragma once

#include <opencv2/core/mat.hpp>

#include "fsp/sim/renderer.h"

namespace fsp::sim::internal {

// Tag36h11 layout: the black square spans 8 of the code's 10 cells; the white margin is one cell.
constexpr int kTagTotalCells = 10;
constexpr int kTagBorderCells = 8;

// Physical size (metres) that the texture of `quad` spans: |axis_u| x |axis_v|, or for kTag the
// square with its white margin (10/8 of the quad).
void TextureExtent(const TexturedQuad& quad, double* width_m, double* height_m);

// Texture size in texels for a density in texels per metre, capped at max_side. Tags get a multiple
// of 10 cells plus one texel, so cell boundaries fall on texel centres.
void TextureSize(const TexturedQuad& quad, double texels_per_m, int max_side, int* width_px,
                 int* height_px);

// CV_32FC1 texture of width_px x height_px, values in [0, 1].
cv::Mat MakeTextureFloat(const TexturedQuad& quad, int width_px, int height_px);

}  // namespace fsp::sim::internal
