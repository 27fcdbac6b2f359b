// Stage 1 of the rectangle detector: edges (Canny with data-driven thresholds) and the straight
// pieces of the traced edge chains.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

#include "fsp/frontend/edge_refine.h"
#include "rect_internal.h"

namespace fsp::frontend::rect_internal {
namespace {

// Edge linking: traces 8-connected chains of Canny pixels (consumes `edges`). At each step the
// unvisited neighbour that best continues the current direction is taken; branches become chains of
// their own. Each chain is traced from its seed in both directions and handed to `on_chain` (a
// buffer reused for every chain).
template <class OnChain>
void TraceChains(cv::Mat& edges, int min_len, OnChain&& on_chain) {
  static const int kDx[8] = {1, 1, 0, -1, -1, -1, 0, 1};
  static const int kDy[8] = {0, 1, 1, 1, 0, -1, -1, -1};
  static const float kInvLen[8] = {1.f, 0.70710678f, 1.f, 0.70710678f,
                                   1.f, 0.70710678f, 1.f, 0.70710678f};
  const int W = edges.cols, H = edges.rows;
  // Border pixels are cleared so neighbour lookups stay inside the image.
  edges.row(0).setTo(0);
  edges.row(H - 1).setTo(0);
  edges.col(0).setTo(0);
  edges.col(W - 1).setTo(0);
  // The walk's heading is the direction over the last few steps (a digital line of slope 1/2
  // alternates between two 8-neighbour steps; a single-step heading would follow any branch at a
  // junction).
  auto walk = [&](cv::Point p, int dir, std::vector<cv::Point>* out) {
    constexpr int kMemory = 4;
    for (;;) {
      cv::Point heading(dir >= 0 ? kDx[dir] : 0, dir >= 0 ? kDy[dir] : 0);
      const int n = static_cast<int>(out->size());
      if (n >= kMemory) heading = p - (*out)[n - kMemory];
      // Score: cosine between step k and the heading (up to the heading's positive length).
      int best = -1;
      float best_score = -1e30f;
      const uint8_t* row_m = edges.ptr<uint8_t>(p.y - 1) + p.x;
      const uint8_t* row_0 = edges.ptr<uint8_t>(p.y) + p.x;
      const uint8_t* row_p = edges.ptr<uint8_t>(p.y + 1) + p.x;
      const uint8_t* rows[3] = {row_m, row_0, row_p};
      for (int k = 0; k < 8; ++k) {
        if (!rows[kDy[k] + 1][kDx[k]]) continue;
        const float score = (dir < 0 && n == 0)
                                ? -static_cast<float>(k)
                                : (kDx[k] * heading.x + kDy[k] * heading.y) * kInvLen[k];
        if (score > best_score) {
          best_score = score;
          best = k;
        }
      }
      if (best < 0 || (dir >= 0 && best_score < 0.0f)) return;  // stop at turns sharper than 90 deg
      p = cv::Point(p.x + kDx[best], p.y + kDy[best]);
      edges.at<uint8_t>(p) = 0;
      out->push_back(p);
      dir = best;
    }
  };
  std::vector<cv::Point> fwd, bwd, chain;  // reused: no allocation per chain
  for (int y = 1; y < H - 1; ++y) {
    const uint8_t* row = edges.ptr<uint8_t>(y);
    for (int x = 1; x < W - 1; ++x) {
      // Skip empty stretches 8 bytes at a time (most of an edge map is empty; the byte-wise scan
      // was ~40 % of the linking time).
      while (x + 8 <= W - 1) {
        uint64_t word;
        std::memcpy(&word, row + x, sizeof(word));
        if (word) break;
        x += 8;
      }
      if (!row[x]) continue;
      const cv::Point seed(x, y);
      edges.at<uint8_t>(seed) = 0;
      fwd.clear();
      bwd.clear();
      walk(seed, -1, &fwd);
      if (!fwd.empty()) {
        // Walk the other way, starting opposite to the first step.
        const cv::Point d = fwd[0] - seed;
        int back = -1;
        for (int k = 0; k < 8; ++k)
          if (kDx[k] == -d.x && kDy[k] == -d.y) back = k;
        walk(seed, back, &bwd);
      }
      if (static_cast<int>(fwd.size() + bwd.size()) + 1 < min_len) continue;
      chain.assign(bwd.rbegin(), bwd.rend());
      chain.push_back(seed);
      chain.insert(chain.end(), fwd.begin(), fwd.end());
      on_chain(chain);
    }
  }
}

// Splits a pixel chain into straight pieces (recursive split at the farthest point from the chord
// while it is farther than tol_px) and fits each piece of at least min_len pixels by total least
// squares.
void SplitChain(const std::vector<cv::Point>& c, int i0, int i1, double tol_px, int min_len,
                std::vector<std::pair<Vec2, Vec2>>* out) {
  if (i1 - i0 + 1 < min_len) return;
  const Vec2 a(c[i0].x, c[i0].y), b(c[i1].x, c[i1].y);
  const Vec2 d = b - a;
  const double L = d.norm();
  int worst = -1;
  double worst_dist = 0.0;
  if (L > 0) {
    const Vec2 n(-d.y() / L, d.x() / L);
    for (int i = i0 + 1; i < i1; ++i) {
      const double dist = std::abs(n.dot(Vec2(c[i].x, c[i].y) - a));
      if (dist > worst_dist) {
        worst_dist = dist;
        worst = i;
      }
    }
  }
  if (worst >= 0 && worst_dist > tol_px) {
    SplitChain(c, i0, worst, tol_px, min_len, out);
    SplitChain(c, worst, i1, tol_px, min_len, out);
    return;
  }
  // Total least squares on the piece's pixels; endpoints = projections of the first and last pixel.
  Vec2 mu = Vec2::Zero();
  for (int i = i0; i <= i1; ++i) mu += Vec2(c[i].x, c[i].y);
  mu /= (i1 - i0 + 1);
  Mat2 S = Mat2::Zero();
  for (int i = i0; i <= i1; ++i) {
    const Vec2 e = Vec2(c[i].x, c[i].y) - mu;
    S += e * e.transpose();
  }
  const Vec2 dir = MajorAxis(S);
  out->emplace_back(mu + dir * dir.dot(a - mu), mu + dir * dir.dot(b - mu));
}

}  // namespace

// Canny thresholds from the gradient statistics. The median Sobel magnitude over (a subsample of)
// the image is dominated by flat regions, where the magnitude of Gaussian noise is
// Rayleigh-distributed: median = 1.177 σ_r. High threshold = max(multiple · σ_r, 4 · min_contrast)
// (Sobel's response to a sharp step of C grey levels is 4C); low = ratio · high.
void CannyThresholds(const cv::Mat& dx, const cv::Mat& dy, const RectDetectorOptions& o,
                     double* low, double* high) {
  constexpr int kBins = 2048;
  std::array<int, kBins> hist{};
  int n = 0;
  // Sobel magnitude (dx, dy: CV_16S, the gradients Canny uses) at every 3rd pixel of every 3rd row
  // (~34k samples at 640x480, plenty for a median).
  for (int y = 1; y < dx.rows - 1; y += 3) {
    const int16_t* gx_row = dx.ptr<int16_t>(y);
    const int16_t* gy_row = dy.ptr<int16_t>(y);
    for (int x = 1; x < dx.cols - 1; x += 3) {
      const int gx = gx_row[x], gy = gy_row[x];
      const double m = std::sqrt(static_cast<double>(gx * gx + gy * gy));
      ++hist[std::min(kBins - 1, static_cast<int>(m))];
      ++n;
    }
  }
  int acc = 0, median = 0;
  for (int b = 0; b < kBins; ++b) {
    acc += hist[b];
    if (2 * acc >= n) {
      median = b;
      break;
    }
  }
  const double sigma_r = (median + 0.5) / 1.177;
  *high = std::max(o.canny_noise_multiple * sigma_r, 4.0 * o.min_edge_contrast);
  *low = o.canny_low_ratio * *high;
}

// Light smoothing (σ = 1 px) against pixel noise, Sobel, Canny with data-driven thresholds. The
// Sobel gradients are computed once (what cv::Canny would compute inside: 3x3, replicated border)
// and serve both the threshold statistics and Canny.
EdgeImages DetectEdges(const cv::Mat& gray, const RectDetectorOptions& o) {
  EdgeImages out;
  out.smooth = EdgeRefineImage(gray);
  cv::spatialGradient(out.smooth, out.dx, out.dy, 3, cv::BORDER_REPLICATE);
  CannyThresholds(out.dx, out.dy, o, &out.canny_low, &out.canny_high);
  cv::Canny(out.dx, out.dy, out.edges, out.canny_low, out.canny_high, true);
  return out;
}

int MinSegmentPx(const RectDetectorOptions& o, double diag) {
  return std::max(4, static_cast<int>(std::lround(o.min_segment_frac * diag)));
}

std::vector<std::pair<Vec2, Vec2>> TracePieces(cv::Mat& edges, int min_piece, double fit_px) {
  std::vector<std::pair<Vec2, Vec2>> raw;
  TraceChains(edges, min_piece, [&](const std::vector<cv::Point>& chain) {
    SplitChain(chain, 0, static_cast<int>(chain.size()) - 1, fit_px, min_piece, &raw);
  });
  return raw;
}

}  // namespace fsp::frontend::rect_internal
