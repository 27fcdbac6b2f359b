#include "textures.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "fsp/common/error.h"

namespace fsp::sim {
namespace internal {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Integer hash (lowbias32-style finaliser) of a lattice point and a seed: the basis of all noise
// here, so textures depend on nothing but their inputs.
uint32_t Hash(int32_t x, int32_t y, uint32_t seed) {
  uint32_t h = seed * 0x9E3779B9u;
  h ^= static_cast<uint32_t>(x) * 0x85EBCA6Bu;
  h = (h << 13) | (h >> 19);
  h ^= static_cast<uint32_t>(y) * 0xC2B2AE35u;
  h ^= h >> 16;
  h *= 0x7FEB352Du;
  h ^= h >> 15;
  h *= 0x846CA68Bu;
  h ^= h >> 16;
  return h;
}

// Uniform in [0, 1) from (x, y, seed).
double Rand01(int32_t x, int32_t y, uint32_t seed) {
  return Hash(x, y, seed) * (1.0 / 4294967296.0);
}

// Value noise in [0, 1]: lattice values at integer points, smoothstep-interpolated.
double ValueNoise(double x, double y, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int32_t ix = static_cast<int32_t>(fx), iy = static_cast<int32_t>(fy);
  double tx = x - fx, ty = y - fy;
  tx = tx * tx * (3.0 - 2.0 * tx);
  ty = ty * ty * (3.0 - 2.0 * ty);
  const double v00 = Rand01(ix, iy, seed), v10 = Rand01(ix + 1, iy, seed);
  const double v01 = Rand01(ix, iy + 1, seed), v11 = Rand01(ix + 1, iy + 1, seed);
  return (v00 * (1 - tx) + v10 * tx) * (1 - ty) + (v01 * (1 - tx) + v11 * tx) * ty;
}

// Fractal sum of value noise, octaves halving in size and amplitude, normalised to [0, 1].
double Fbm(double x, double y, uint32_t seed, int octaves) {
  double sum = 0.0, amp = 1.0, norm = 0.0, f = 1.0;
  for (int k = 0; k < octaves; ++k) {
    sum += amp * ValueNoise(x * f, y * f, seed + 1013u * static_cast<uint32_t>(k));
    norm += amp;
    amp *= 0.5;
    f *= 2.0;
  }
  return sum / norm;
}

// Fills tex (CV_32F) with f(x_m, y_m): x from the left edge, y up from the bottom edge, in metres;
// each texel averages ss x ss samples over its footprint (box filter).
template <class F>
void Fill(cv::Mat* tex, double width_m, double height_m, int ss, const F& f) {
  const int W = tex->cols, H = tex->rows;
  const double dx = width_m / std::max(W - 1, 1), dy = height_m / std::max(H - 1, 1);
  const double inv = 1.0 / (ss * ss);
  // Rows are independent (f is pure), so the parallel fill gives the same texels as a serial one.
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int j = rows.start; j < rows.end; ++j) {
      float* row = tex->ptr<float>(j);
      const double y0 = height_m - j * dy;
      for (int i = 0; i < W; ++i) {
        const double x0 = i * dx;
        double sum = 0.0;
        for (int sj = 0; sj < ss; ++sj)
          for (int si = 0; si < ss; ++si)
            sum += f(x0 + ((si + 0.5) / ss - 0.5) * dx, y0 + ((sj + 0.5) / ss - 0.5) * dy);
        row[i] = static_cast<float>(sum * inv);
      }
    }
  });
}

// Distance (metres) from (x, y) to the nearest edge of the [0, w] x [0, h] rectangle, negative
// outside.
double EdgeDistance(double x, double y, double w, double h) {
  return std::min(std::min(x, w - x), std::min(y, h - y));
}

bool InBox(double x, double y, double x0, double y0, double x1, double y1) {
  return x >= x0 && x <= x1 && y >= y0 && y <= y1;
}

// Wall: plaster (fractal noise) or wallpaper (faint vertical stripes and a small motif), chosen by
// seed; CONTRAST scales the plaster (paint: 0.2, never wallpaper).
void PaintWall(cv::Mat* tex, double w, double h, uint32_t seed, double contrast = 1.0) {
  const double base = 0.56 + 0.10 * Rand01(1, 0, seed);
  const bool wallpaper = contrast == 1.0 && Hash(2, 0, seed) % 3 == 0;
  const double period = 0.10 + 0.06 * Rand01(3, 0, seed);
  Fill(tex, w, h, 1, [&](double x, double y) {
    double v = base + contrast * (0.08 * (Fbm(x / 0.05, y / 0.05, seed, 3) - 0.5) +
                                  0.05 * (ValueNoise(x / 0.7, y / 0.7, seed + 7u) - 0.5));
    if (wallpaper) {
      const double s = std::sin(2.0 * kPi * x / period);
      v += 0.025 * s;
      // A small motif (dots) between the stripes, staggered by row.
      const double row = std::floor(y / period);
      const double cx =
          (std::floor(x / period) + 0.5 + 0.5 * std::fmod(std::abs(row), 2.0)) * period;
      const double cy = (row + 0.5) * period;
      const double r = std::hypot(x - cx, y - cy);
      if (r < 0.12 * period) v -= 0.05;
    }
    return v;
  });
}

// Floor: square tiles with grout, or staggered planks with grain, chosen by seed.
void PaintFloor(cv::Mat* tex, double w, double h, uint32_t seed) {
  const bool planks = Hash(2, 1, seed) % 2 == 1;
  if (!planks) {
    const double size = 0.4 + 0.2 * Rand01(3, 1, seed), grout = 0.006;
    Fill(tex, w, h, 1, [&](double x, double y) {
      const double tx = std::floor(x / size), ty = std::floor(y / size);
      const double lx = x - tx * size, ly = y - ty * size;
      if (lx < grout || ly < grout) return 0.28;
      const double tile =
          0.42 + 0.12 * Rand01(static_cast<int32_t>(tx), static_cast<int32_t>(ty), seed + 5u);
      return tile + 0.06 * (Fbm(x / 0.04, y / 0.04, seed + 9u, 2) - 0.5);
    });
  } else {
    const double width = 0.16 + 0.06 * Rand01(3, 1, seed), length = 1.2, gap = 0.003;
    Fill(tex, w, h, 1, [&](double x, double y) {
      const double row = std::floor(y / width);
      const double shift = length * Rand01(static_cast<int32_t>(row), 0, seed + 11u);
      const double col = std::floor((x + shift) / length);
      const double lx = x + shift - col * length, ly = y - row * width;
      if (lx < gap || ly < gap) return 0.18;
      const uint32_t plank = Hash(static_cast<int32_t>(col), static_cast<int32_t>(row), seed + 13u);
      const double tone = 0.32 + 0.18 * (plank >> 8) * (1.0 / 16777216.0);
      const double grain =
          std::sin(2.0 * kPi * (ly / 0.012 + 3.0 * Fbm(x / 0.5, ly / 0.05, plank, 2)));
      return tone + 0.05 * grain + 0.04 * (Fbm(x / 0.03, y / 0.01, plank + 1u, 2) - 0.5);
    });
  }
}

// Ceiling: light panels in a grid with darker rails.
void PaintCeiling(cv::Mat* tex, double w, double h, uint32_t seed) {
  const double size = 0.6, rail = 0.018;
  Fill(tex, w, h, 1, [&](double x, double y) {
    const double lx = x - std::floor(x / size) * size, ly = y - std::floor(y / size) * size;
    if (lx < rail || ly < rail) return 0.55;
    return 0.80 + 0.05 * (Fbm(x / 0.01, y / 0.01, seed, 2) - 0.5);
  });
}

// Frame width of an object: a fraction of its smaller side, within [lo, hi] metres.
double FrameWidth(double w, double h, double frac, double lo, double hi) {
  return std::clamp(frac * std::min(w, h), lo, hi);
}

// Wood (doors): vertical grain, a dark outer frame, two recessed panels and a handle for door-sized
// quads.
void PaintWood(cv::Mat* tex, double w, double h, uint32_t seed) {
  const double fw = FrameWidth(w, h, 0.06, 0.02, 0.08);
  const double base = 0.46 + 0.12 * Rand01(1, 2, seed);
  const bool door = h > 1.5 && w > 0.4 && w < 1.4;
  const double inset = std::min(0.15, 0.2 * std::min(w, h)), line = 0.012;
  Fill(tex, w, h, 2, [&](double x, double y) {
    if (EdgeDistance(x, y, w, h) < fw) return 0.2;
    double v =
        base +
        0.06 * std::sin(2.0 * kPi * (x / 0.011 + 4.0 * Fbm(x / 0.3, y / 1.5, seed + 3u, 3))) +
        0.05 * (Fbm(x / 0.02, y / 0.3, seed + 4u, 2) - 0.5);
    if (door) {
      // Two panels: lower [inset, 0.45h], upper [0.5h, h - inset]; their outlines are grooves.
      const double xs[2] = {inset, w - inset};
      const double ys[2][2] = {{inset, 0.45 * h}, {0.5 * h, h - inset}};
      for (const auto& p : ys) {
        const bool outer = InBox(x, y, xs[0], p[0], xs[1], p[1]);
        const bool inner = InBox(x, y, xs[0] + line, p[0] + line, xs[1] - line, p[1] - line);
        if (outer && !inner) v -= 0.16;
      }
      // Handle: a dark knob on a plate, 0.1 m from the right edge at 1 m height.
      const double hx = w - std::max(fw + 0.05, 0.1), hy = std::min(1.0, 0.48 * h);
      if (InBox(x, y, hx - 0.02, hy - 0.08, hx + 0.02, hy + 0.08)) v = 0.55;
      if (std::hypot(x - hx, y - hy) < 0.025) v = 0.12;
    }
    return v;
  });
}

// Glass (windows): bright sky-like pane with soft clouds, a dark frame and a cross of mullions.
void PaintGlass(cv::Mat* tex, double w, double h, uint32_t seed) {
  const double fw = FrameWidth(w, h, 0.06, 0.03, 0.08), mw = 0.6 * fw;
  const double mx = w * (0.45 + 0.1 * Rand01(1, 3, seed)),
               my = h * (0.55 + 0.1 * Rand01(2, 3, seed));
  Fill(tex, w, h, 2, [&](double x, double y) {
    if (EdgeDistance(x, y, w, h) < fw) return 0.2;
    if (std::abs(x - mx) < 0.5 * mw || std::abs(y - my) < 0.5 * mw) return 0.22;
    return 0.80 + 0.10 * y / h + 0.08 * (Fbm(x / 0.25, y / 0.12, seed, 4) - 0.5);
  });
}

// Cabinet front: body with fine noise, dark frame, one or two doors with inset panel outlines and
// handles.
void PaintCabinet(cv::Mat* tex, double w, double h, uint32_t seed) {
  const double fw = FrameWidth(w, h, 0.04, 0.02, 0.05);
  const double base = 0.50 + 0.15 * Rand01(1, 4, seed);
  const int doors = w > 0.8 ? 2 : 1;
  const double dw = (w - 2 * fw) / doors, inset = std::min(0.06, 0.15 * std::min(dw, h)),
               line = 0.008;
  const double handle_y = h * (0.55 + 0.2 * Rand01(2, 4, seed));
  Fill(tex, w, h, 2, [&](double x, double y) {
    if (EdgeDistance(x, y, w, h) < fw) return 0.25;
    double v = base + 0.04 * (Fbm(x / 0.02, y / 0.02, seed, 2) - 0.5);
    const int d = std::clamp(static_cast<int>((x - fw) / dw), 0, doors - 1);
    const double x0 = fw + d * dw, x1 = x0 + dw;
    if (doors == 2 && std::abs(x - (fw + dw)) < 0.004) return 0.2;  // gap between the doors
    const bool outer = InBox(x, y, x0 + inset, fw + inset, x1 - inset, h - fw - inset);
    const bool inner =
        InBox(x, y, x0 + inset + line, fw + inset + line, x1 - inset - line, h - fw - inset - line);
    if (outer && !inner) v -= 0.15;
    // Vertical bar handle near the door's opening side.
    const double hx =
        (doors == 2) ? (d == 0 ? x1 - 0.5 * inset : x0 + 0.5 * inset) : x1 - 0.5 * inset;
    if (std::abs(x - hx) < 0.008 && std::abs(y - handle_y) < std::min(0.06, 0.15 * h)) v = 0.1;
    return v;
  });
}

// Poster: light paper, a dark frame, a few shapes at several grey levels and one line of text.
void PaintPoster(cv::Mat* tex, double w, double h, uint32_t seed) {
  const int W = tex->cols, H = tex->rows;
  cv::Mat img(H, W, CV_8UC1, cv::Scalar(228));
  std::mt19937 rng(seed);
  auto u01 = [&rng]() { return rng() * (1.0 / 4294967296.0); };
  const double sx = (W - 1) / w, sy = (H - 1) / h;  // texels per metre
  const double fw = FrameWidth(w, h, 0.03, 0.01, 0.04);
  const int fx = std::max(1, static_cast<int>(std::lround(fw * sx)));
  const int fy = std::max(1, static_cast<int>(std::lround(fw * sy)));
  constexpr int kShift = 4;               // sub-texel precision of the drawing calls
  auto P = [&](double x_m, double y_m) {  // metres (y up) -> fixed-point texel coordinates
    return cv::Point(static_cast<int>(std::lround(x_m * sx * (1 << kShift))),
                     static_cast<int>(std::lround((h - y_m) * sy * (1 << kShift))));
  };
  // Shapes in the upper three quarters.
  const int nshapes = 3 + static_cast<int>(rng() % 4);
  for (int k = 0; k < nshapes; ++k) {
    const cv::Scalar grey(20 + static_cast<int>(u01() * 150));
    const double cx = (0.15 + 0.7 * u01()) * w, cy = (0.35 + 0.5 * u01()) * h;
    const double r = (0.08 + 0.12 * u01()) * std::min(w, h);
    switch (rng() % 3) {
      case 0:
        cv::rectangle(img, P(cx - r, cy - 0.7 * r), P(cx + r, cy + 0.7 * r), grey, cv::FILLED,
                      cv::LINE_AA, kShift);
        break;
      case 1:
        cv::circle(img, P(cx, cy), static_cast<int>(std::lround(r * sx * (1 << kShift))), grey,
                   cv::FILLED, cv::LINE_AA, kShift);
        break;
      default: {
        const std::vector<cv::Point> tri = {P(cx - r, cy - r), P(cx + r, cy - r), P(cx, cy + r)};
        cv::fillPoly(img, std::vector<std::vector<cv::Point>>{tri}, grey, cv::LINE_AA, kShift);
      }
    }
  }
  // One line of text across the bottom quarter.
  static const char* const kWords[] = {"FSP-SLAM",     "ROOM 101",    "EXHIBIT",
                                       "QUIET PLEASE", "SUMMER 1999", "VISIT THE LAB",
                                       "SEMINAR 4PM",  "NO ENTRY"};
  const std::string text = kWords[rng() % (sizeof(kWords) / sizeof(kWords[0]))];
  int baseline = 0;
  const cv::Size unit = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, 1.0, 2, &baseline);
  const double scale = std::min(0.75 * (W - 2 * fx) / unit.width, 0.12 * H / unit.height);
  if (scale > 0.2) {
    const int thickness = std::max(1, static_cast<int>(std::lround(2 * scale)));
    const cv::Size ts =
        cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, thickness, &baseline);
    cv::putText(img, text, cv::Point((W - ts.width) / 2, H - fy - static_cast<int>(0.08 * H)),
                cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(30), thickness, cv::LINE_AA);
  }
  // Frame last so that it stays crisp.
  img.rowRange(0, std::min(fy, H)).setTo(40);
  img.rowRange(std::max(H - fy, 0), H).setTo(40);
  img.colRange(0, std::min(fx, W)).setTo(40);
  img.colRange(std::max(W - fx, 0), W).setTo(40);
  img.convertTo(*tex, CV_32F, 1.0 / 255.0);
}

// Tag36h11 code `tag_id` as a 10 x 10 grid of cells (row 0 at the top), 1 = white, following the
// family table's layout exactly as the library's own apriltag_to_image does: white margin ring,
// black border ring, data bits at (bit_x, bit_y) inside the border (most significant bit first).
std::array<std::array<uint8_t, kTagTotalCells>, kTagTotalCells> TagCells(int tag_id) {
  apriltag_family_t* fam = tag36h11_create();
  if (tag_id < 0 || static_cast<uint32_t>(tag_id) >= fam->ncodes) {
    const uint32_t n = fam->ncodes;
    tag36h11_destroy(fam);
    throw InputError("tag id " + std::to_string(tag_id) + " is not a tag36h11 code (0.." +
                     std::to_string(n - 1) + ")");
  }
  FSP_CHECK(fam->total_width == kTagTotalCells && fam->width_at_border == kTagBorderCells &&
            !fam->reversed_border);
  std::array<std::array<uint8_t, kTagTotalCells>, kTagTotalCells> cells{};
  const int white_width = fam->width_at_border + 2;
  const int white_start = (fam->total_width - white_width) / 2;
  for (int i = 0; i < white_width; ++i) {
    cells[white_start][white_start + i] = 1;
    cells[white_start + white_width - 1][white_start + i] = 1;
    cells[white_start + i][white_start] = 1;
    cells[white_start + i][white_start + white_width - 1] = 1;
  }
  const int border_start = (fam->total_width - fam->width_at_border) / 2;
  const uint64_t code = fam->codes[tag_id];
  for (uint32_t i = 0; i < fam->nbits; ++i)
    if (code & (uint64_t{1} << (fam->nbits - i - 1)))
      cells[fam->bit_y[i] + border_start][fam->bit_x[i] + border_start] = 1;
  tag36h11_destroy(fam);
  return cells;
}

void PaintTag(cv::Mat* tex, int tag_id) {
  const auto cells = TagCells(tag_id);
  const double n = kTagTotalCells;
  // Coordinates in cells: x from the left, y up from the bottom; 4 x 4 box filter per texel, so a
  // cell boundary on a texel centre gives exactly the mid grey.
  Fill(tex, n, n, 4, [&](double x, double y) {
    const int cx = std::clamp(static_cast<int>(std::floor(x)), 0, kTagTotalCells - 1);
    const int row = std::clamp(static_cast<int>(std::floor(n - y)), 0, kTagTotalCells - 1);
    return cells[row][cx] ? 0.95 : 0.05;
  });
}

// Plain: uniform bright face and a dark border (10 % of the smaller side).
void PaintPlain(cv::Mat* tex, double w, double h) {
  const double bw = 0.1 * std::min(w, h);
  Fill(tex, w, h, 4, [&](double x, double y) { return EdgeDistance(x, y, w, h) < bw ? 0.1 : 0.9; });
}

}  // namespace

void TextureExtent(const TexturedQuad& quad, double* width_m, double* height_m) {
  const double k =
      quad.texture == TextureKind::kTag ? double(kTagTotalCells) / kTagBorderCells : 1.0;
  *width_m = k * quad.axis_u_W.norm();
  *height_m = k * quad.axis_v_W.norm();
}

void TextureSize(const TexturedQuad& quad, double texels_per_m, int max_side, int* width_px,
                 int* height_px) {
  double w_m = 0.0, h_m = 0.0;
  TextureExtent(quad, &w_m, &h_m);
  if (quad.texture == TextureKind::kTag) {
    // (10 m + 1) texels: cell boundaries on texel centres; at least 16 texels per cell (sharp up
    // close).
    const int max_m = std::max(1, (max_side - 1) / kTagTotalCells);
    const int m =
        std::clamp(static_cast<int>(std::ceil(std::max(w_m, h_m) * texels_per_m / kTagTotalCells)),
                   std::min(16, max_m), max_m);
    *width_px = *height_px = kTagTotalCells * m + 1;
    return;
  }
  auto side = [&](double len_m) {
    return std::clamp(static_cast<int>(std::lround(len_m * texels_per_m)) + 1, 2, max_side);
  };
  *width_px = side(w_m);
  *height_px = side(h_m);
}

cv::Mat MakeTextureFloat(const TexturedQuad& quad, int width_px, int height_px) {
  FSP_CHECK(width_px >= 2 && height_px >= 2);
  cv::Mat tex(height_px, width_px, CV_32FC1, cv::Scalar(0));
  double w = 0.0, h = 0.0;
  TextureExtent(quad, &w, &h);
  const uint32_t seed = quad.seed;
  switch (quad.texture) {
    case TextureKind::kWall:
      PaintWall(&tex, w, h, seed);
      break;
    case TextureKind::kFloor:
      PaintFloor(&tex, w, h, seed);
      break;
    case TextureKind::kCeiling:
      PaintCeiling(&tex, w, h, seed);
      break;
    case TextureKind::kWood:
      PaintWood(&tex, w, h, seed);
      break;
    case TextureKind::kGlass:
      PaintGlass(&tex, w, h, seed);
      break;
    case TextureKind::kCabinet:
      PaintCabinet(&tex, w, h, seed);
      break;
    case TextureKind::kPoster:
      PaintPoster(&tex, w, h, seed);
      break;
    case TextureKind::kTag:
      PaintTag(&tex, quad.tag_id);
      break;
    case TextureKind::kPlain:
      PaintPlain(&tex, w, h);
      break;
    case TextureKind::kPaint:
      PaintWall(&tex, w, h, seed, 0.2);
      break;
  }
  cv::min(cv::max(tex, 0.0), 1.0, tex);
  return tex;
}

}  // namespace internal

cv::Mat MakeTexture(const TexturedQuad& quad, int width_px, int height_px) {
  cv::Mat out;
  internal::MakeTextureFloat(quad, width_px, height_px).convertTo(out, CV_8UC1, 255.0);
  return out;
}

}  // namespace fsp::sim
