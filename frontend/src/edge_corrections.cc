// The side corrections that run after the sub-pixel refinement (edge_refine.cc, CorrectSides): a
// framed object's side found on its frame's inner edge moved out onto the outline, a bright
// object's side found on its shadow's outer edge moved in onto the object (frame_band_max_frac),
// and a side beside a thin band moved off the blur's push (band_max_px). The detector applies them
// to its detections, RefineCornersOnEdges to every refined quad.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <Eigen/Dense>

#include "fsp/common/median.h"
#include "fsp/frontend/rect_geometry.h"
#include "rect_internal.h"

namespace fsp::frontend::rect_internal {

// Frame outline (RectDetectorOptions::frame_band_max_frac). Along each side, at kPositions points
// of its middle 70 %, the grey 1.5 px inside and outside; a side's contrast is the median of inside
// - outside. The band on the opposite side: the 1-D profile inward from its outline, the strongest
// step of the odd side's polarity from 1 px on (a parabola through the steps for its sub-pixel
// place). All on the smoothed image the refinement reads (distorted), at undistorted points.
namespace {

constexpr int kPositions = 12;

// Grey of the smoothed image at undistorted point p; false outside.
bool GreyAt(const EdgeProbe& probe, const Vec2& p, double* v) {
  const Vec2 d = probe.cam ? probe.cam->DistortPixel(p) : p;
  return Bilinear(probe.smooth, d.x(), d.y(), v);
}

// The unit normal of side P -> Q pointing into the quad (towards `centre`).
Vec2 InwardNormal(const Vec2& P, const Vec2& Q, const Vec2& centre) {
  const Vec2 u = (Q - P).normalized();
  Vec2 n(-u.y(), u.x());
  if (n.dot(centre - 0.5 * (P + Q)) < 0.0) n = -n;
  return n;
}

// The k-th sample position along a side, as a fraction of it from P.
double PositionT(int k) {
  return 0.15 + 0.7 * (k + 0.5) / kPositions;
}

constexpr double kProfileStep = 0.5;  // spacing of the inward profiles [px]

// The grey profile inward from b along n: samples 0..K+1, kProfileStep apart; false where one
// leaves the image.
bool InwardProfile(const EdgeProbe& probe, const Vec2& b, const Vec2& n, int K,
                   std::vector<double>* prof) {
  prof->resize(static_cast<size_t>(K + 2));
  for (int s = 0; s <= K + 1; ++s)
    if (!GreyAt(probe, b + (s * kProfileStep) * n, &(*prof)[s])) return false;
  return true;
}

// The sample s in [2, K) of PROF's strongest step SIGN x (prof[s+1] - prof[s-1]) > 0 [grey levels
// per px] (-1: none), its size in *D.
int StrongestStep(const std::vector<double>& prof, int K, int sign, double* d) {
  int best = -1;
  *d = 0.0;
  for (int s = 2; s < K; ++s) {
    const double step = sign * (prof[s + 1] - prof[s - 1]);
    if (step > *d) {
      *d = step;
      best = s;
    }
  }
  return best;
}

// A band's width from its widths at the kPositions places: their median *W when at least 2/3 of
// the places gave one and 2/3 lie within 1 px of it.
bool ConsistentWidth(const std::vector<double>& widths, double* w) {
  if (static_cast<int>(widths.size()) < 2 * kPositions / 3) return false;
  *w = Median(widths);
  int consistent = 0;
  for (double x : widths) consistent += std::abs(x - *w) <= 1.0;
  return consistent >= 2 * kPositions / 3;
}

// Side j of quad C moved along its inward normal by SHIFT_IN [px] (negative: outward), onto an edge
// found within 1.5 px of there (else exactly there), and the corners re-intersected; false (C
// unchanged) when the result is not a convex quad.
bool SnapSide(const EdgeProbe& probe, int j, double shift_in, Corners* corners) {
  Corners& c = *corners;
  const Vec2 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  const Vec2 P = c[(j + 3) % 4], Q = c[j], n = InwardNormal(P, Q, centre);
  Line line;
  line.n = n;
  line.c = n.dot(P) + shift_in;
  std::vector<Vec2> pts;
  std::vector<double> wts;
  for (int k = 0; k < kPositions; ++k) {
    const Vec2 b = P + PositionT(k) * (Q - P) + shift_in * n;
    std::array<double, 9> v{};  // -2 .. +2 px along n, 0.5 px apart
    bool ok = true;
    for (int s = 0; s < 9 && ok; ++s) ok = GreyAt(probe, b + (0.5 * (s - 4)) * n, &v[s]);
    if (!ok) continue;
    int best = -1;
    double best_d = 0.0;
    for (int s = 1; s < 8; ++s) {
      const double d = std::abs(v[s + 1] - v[s - 1]);
      if (d > best_d) {
        best_d = d;
        best = s;
      }
    }
    if (best <= 1 || best >= 7 || best_d < 2.0) continue;
    pts.push_back(b + (0.5 * (best - 4)) * n);
    wts.push_back(best_d);
  }
  if (static_cast<int>(pts.size()) >= 2 * kPositions / 3) {
    std::vector<int> idx(pts.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<int>(i);
    Line found;
    if (FitLineTls(pts, wts, idx, &found)) {
      if (found.n.dot(n) < 0.0) {
        found.n = -found.n;
        found.c = -found.c;
      }
      const double shift = std::abs(found.c - line.c);
      if (found.n.dot(n) > std::cos(3.0 * M_PI / 180.0) && shift <= 1.5) line = found;
    }
  }
  // New corners: the moved line with the two neighbouring sides' lines.
  const int a = (j + 3) % 4, b = j;
  const Line before = LineOf(MakeSeg(c[(j + 2) % 4], c[a]));
  const Line after = LineOf(MakeSeg(c[b], c[(j + 1) % 4]));
  Vec2 ca, cb;
  if (!Intersect(before, line, &ca) || !Intersect(line, after, &cb)) return false;
  Corners moved = c;
  moved[a] = ca;
  moved[b] = cb;
  if (!IsConvex(moved)) return false;
  c = moved;
  return true;
}

// A bright object's side j found on the outer edge of its shadow on the wall (a switch plate's, a
// sheet's: a shadow falls on one side, a frame runs round; tried when FrameOutline finds no frame):
// its inside darker than its outside where the three other sides' is brighter.
// Inward from it within MAX_D, each position's strongest rise to the object's grey (at least half
// the other sides' median contrast); consistent over 2/3 of the positions, the side moves onto it.
bool MoveOffShadow(const EdgeProbe& probe, int j, const std::array<double, 4>& contrast,
                   double max_d, Corners* corners) {
  const Corners& c = *corners;
  if (!(contrast[j] < 0.0)) return false;
  std::vector<double> others;
  for (int i = 0; i < 4; ++i)
    if (i != j) others.push_back(contrast[i]);
  const double object_contrast = Median(others);
  if (!(object_contrast > 0.0)) return false;
  const Vec2 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  const Vec2 P = c[(j + 3) % 4], Q = c[j], n = InwardNormal(P, Q, centre);
  const int K = static_cast<int>(max_d / kProfileStep);
  if (K < 4) return false;
  std::vector<double> widths, prof;
  for (int k = 0; k < kPositions; ++k) {
    if (!InwardProfile(probe, P + PositionT(k) * (Q - P), n, K, &prof)) continue;
    double rise;  // into the object
    const int best = StrongestStep(prof, K, 1, &rise);
    if (best < 0 || rise < 0.5 * object_contrast) continue;
    widths.push_back(best * kProfileStep);
  }
  double w;
  if (!ConsistentWidth(widths, &w) || w < 1.0) return false;
  return SnapSide(probe, j, w, corners);
}

// The frame outline of MoveOntoFrameOutline for odd side j (its steps after finding j).
bool FrameOutline(const EdgeProbe& probe, int j, const std::array<double, 4>& contrast,
                  const std::array<int, 4>& pol, double max_d, Corners* corners) {
  Corners& c = *corners;
  const Vec2 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  const int opp = (j + 2) % 4;
  // The band on the opposite side: from its outline inward to a step of side j's polarity.
  const Vec2 Po = c[(opp + 3) % 4], Qo = c[opp], no = InwardNormal(Po, Qo, centre);
  const int K = static_cast<int>(max_d / kProfileStep);
  if (K < 4) return false;
  std::vector<double> widths, band, panel, prof;
  for (int k = 0; k < kPositions; ++k) {
    if (!InwardProfile(probe, Po + PositionT(k) * (Qo - Po), no, K, &prof)) continue;
    double best_d;
    const int best = StrongestStep(prof, K, pol[j], &best_d);
    if (best < 0 || best_d < 0.25 * std::abs(contrast[j])) continue;
    const double dm = pol[j] * (prof[best] - prof[best - 2]);
    const double dp = best + 2 <= K + 1 ? pol[j] * (prof[best + 2] - prof[best]) : best_d;
    const double den = dm - 2.0 * best_d + dp;
    const double delta = den < 0.0 ? std::clamp(0.5 * (dm - dp) / den, -0.5, 0.5) : 0.0;
    widths.push_back((best + delta) * kProfileStep);
    band.push_back(prof[static_cast<size_t>(best / 2)]);
    panel.push_back(prof[static_cast<size_t>(std::min(best + 3, K + 1))]);
  }
  double w_opp;
  if (!ConsistentWidth(widths, &w_opp)) return false;
  const double grey_band = Median(band);
  const double frame_contrast = std::abs(Median(panel) - grey_band);
  // Side j is a frame's inner edge: its contrast is the frame's, not a faint outline's.
  if (std::abs(contrast[j]) < 0.5 * frame_contrast || frame_contrast < 16.0) return false;
  // The band's width at side j and its grey outside side j (not inside it: there is the panel).
  const Vec2 P = c[(j + 3) % 4], Q = c[j], n = InwardNormal(P, Q, centre);
  const double w_j = w_opp * (Q - P).norm() / (Qo - Po).norm();
  if (w_j < 1.0 || w_j > max_d) return false;
  std::vector<double> outside, inside;
  for (int k = 0; k < kPositions; ++k) {
    const Vec2 b = P + PositionT(k) * (Q - P);
    double v1, v2, v3;
    if (GreyAt(probe, b - 0.3 * w_j * n, &v1) && GreyAt(probe, b - 0.7 * w_j * n, &v2) &&
        GreyAt(probe, b + 0.5 * w_j * n, &v3)) {
      outside.push_back(std::max(std::abs(v1 - grey_band), std::abs(v2 - grey_band)));
      inside.push_back(std::abs(v3 - grey_band));
    }
  }
  if (static_cast<int>(outside.size()) < kPositions / 2 || Median(outside) > 0.4 * frame_contrast ||
      Median(inside) < 0.5 * frame_contrast)
    return false;
  return SnapSide(probe, j, -w_j, &c);
}

// The frame outline and the shadow (frame_band_max_frac); returns the side moved off a shadow,
// else -1.
int MoveOntoFrameOutline(const EdgeProbe& probe, Corners* corners) {
  const RectDetectorOptions& o = probe.o;
  if (!(o.frame_band_max_frac > 0.0)) return -1;
  Corners& c = *corners;
  const Vec2 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  std::array<double, 4> contrast{};
  std::array<int, 4> pol{};
  for (int i = 0; i < 4; ++i) {
    const Vec2 P = c[(i + 3) % 4], Q = c[i], n = InwardNormal(P, Q, centre);
    std::vector<double> diffs;
    for (int k = 0; k < kPositions; ++k) {
      const Vec2 b = P + PositionT(k) * (Q - P);
      double vin, vout;
      if (GreyAt(probe, b + 1.5 * n, &vin) && GreyAt(probe, b - 1.5 * n, &vout))
        diffs.push_back(vin - vout);
    }
    if (static_cast<int>(diffs.size()) < kPositions / 2) return -1;
    contrast[i] = Median(diffs);
    pol[i] = contrast[i] > 0.0 ? 1 : -1;
  }
  // The odd side: its inside brighter (darker) where the three others' is darker (brighter).
  int j = -1;
  for (int i = 0; i < 4; ++i)
    if (pol[i] != pol[(i + 1) % 4] && pol[i] != pol[(i + 3) % 4]) j = i;
  if (j < 0) return -1;
  const double max_d = o.frame_band_max_frac * ShortestSide(c);
  if (FrameOutline(probe, j, contrast, pol, max_d, &c)) return -1;
  return MoveOffShadow(probe, j, contrast, max_d, &c) ? j : -1;
}

}  // namespace

// Thin bands (RectDetectorOptions::band_max_px). Across each side, at kPositions points of its
// middle 70 %, the profile of the smoothed image from -R to +R px along the side's normal; their
// median per offset is the side's profile. Where an edge of the opposite polarity lies within
// band_max_px of the side's gradient peak on one side of it (a frame's inner edge), the profile is
// fitted with a blurred step per edge, y(s) = B + c1 Phi((s - a1) / sg) + c2 Phi((s - a2) / sg)
// (Levenberg-Marquardt, all six free), and the side moves from the peak to its step's a: blurred
// edges' gradients overlap and push each other's peaks apart, by ~w exp(-w^2 / 2 sg^2) for a band
// of width w. For bands thinner than the blur the profile fixes the band's centre better than its
// width, so a part of the push remains (tests/frontend/test_edge_refine.cc: 1-3 px frames).
namespace {

constexpr double kBandStep = 0.5;  // profile sample spacing [px]

// Fits theta = {B, c_1..c_m, a_1..a_m, log sg} (initial values in, fit out) to samples (s, y);
// RMS: the fit's RMS residual [grey levels].
bool FitEdges(const std::vector<double>& s, const std::vector<double>& y, Eigen::VectorXd* theta,
              double* rms) {
  const int m = static_cast<int>((theta->size() - 2) / 2);
  const int np = static_cast<int>(theta->size());
  const double kInvSqrt2 = 1.0 / std::sqrt(2.0), kInvSqrt2Pi = 1.0 / std::sqrt(2.0 * M_PI);
  Eigen::VectorXd J(np);
  auto evaluate = [&](const Eigen::VectorXd& t, Eigen::MatrixXd* H, Eigen::VectorXd* g) {
    const double sg = std::exp(t[np - 1]);
    double cost = 0.0;
    if (H) H->setZero(np, np);
    if (g) g->setZero(np);
    for (size_t k = 0; k < s.size(); ++k) {
      double r = t[0] - y[k];
      J.setZero();
      J[0] = 1.0;
      for (int e = 0; e < m; ++e) {
        const double z = (s[k] - t[1 + m + e]) / sg;
        const double P = 0.5 * std::erfc(-z * kInvSqrt2);
        r += t[1 + e] * P;
        if (!H) continue;
        const double f = kInvSqrt2Pi * std::exp(-0.5 * z * z);
        J[1 + e] = P;
        J[1 + m + e] = -t[1 + e] * f / sg;
        J[np - 1] -= t[1 + e] * f * z;
      }
      cost += r * r;
      if (!H) continue;
      H->selfadjointView<Eigen::Lower>().rankUpdate(J);
      *g += J * r;
    }
    if (H) *H = H->selfadjointView<Eigen::Lower>();
    return cost;
  };
  Eigen::VectorXd t = *theta, g;
  Eigen::MatrixXd H;
  double cost = evaluate(t, &H, &g), lambda = 1e-3;
  bool converged = false;
  for (int it = 0; it < 20 && !converged; ++it) {
    Eigen::MatrixXd A = H;
    A.diagonal() += lambda * H.diagonal() + Eigen::VectorXd::Constant(np, 1e-12);
    const Eigen::VectorXd dx = A.ldlt().solve(-g);
    if (!dx.allFinite()) return false;
    const Eigen::VectorXd tn = t + dx;
    const double cn = evaluate(tn, nullptr, nullptr);
    if (cn < cost) {
      converged = dx.tail(m + 1).cwiseAbs().maxCoeff() < 1e-4;
      t = tn;
      cost = evaluate(t, &H, &g);
      lambda = std::max(lambda / 3.0, 1e-9);
    } else {
      lambda *= 4.0;
      converged = lambda > 1e6;
    }
  }
  *theta = t;
  *rms = std::sqrt(cost / static_cast<double>(s.size()));
  return t.allFinite();
}

// The offset [px, along n] from side P -> Q's gradient peak to the edge of the model, when an edge
// of the opposite polarity lies within band_max_px; false (no move) otherwise.
bool BandOffset(const EdgeProbe& probe, const Vec2& P, const Vec2& Q, const Vec2& n, bool n_inward,
                double* offset) {
  const RectDetectorOptions& o = probe.o;
  const int K = static_cast<int>(std::ceil((o.band_max_px + 2.5) / kBandStep));
  const int N = 2 * K + 1;
  std::vector<std::vector<double>> at(N);  // grey per offset, over the positions
  std::vector<double> v(N);
  for (int k = 0; k < kPositions; ++k) {
    const Vec2 b = P + PositionT(k) * (Q - P);
    bool ok = true;
    for (int i = 0; i < N && ok; ++i) ok = GreyAt(probe, b + ((i - K) * kBandStep) * n, &v[i]);
    if (!ok) continue;
    for (int i = 0; i < N; ++i) at[i].push_back(v[i]);
  }
  if (static_cast<int>(at[0].size()) < 2 * kPositions / 3) return false;
  std::vector<double> s(N), y(N), grad(N, 0.0);
  for (int i = 0; i < N; ++i) {
    s[i] = (i - K) * kBandStep;
    y[i] = Median(at[i]);
  }
  const int d = static_cast<int>(std::lround(0.5 / kBandStep));  // central difference over 1 px
  for (int i = d; i < N - d; ++i) grad[i] = y[i + d] - y[i - d];
  // The side's peak: the strongest gradient within 1 px of the line.
  const int one_px = static_cast<int>(std::lround(1.0 / kBandStep));
  int pk = -1;
  for (int i = K - one_px; i <= K + one_px; ++i)
    if (pk < 0 || std::abs(grad[i]) > std::abs(grad[pk])) pk = i;
  const double pol = grad[pk] > 0.0 ? 1.0 : -1.0;
  if (std::abs(grad[pk]) < 2.0) return false;
  // The maximum of sign * f near sample i: the vertex of the parabola through i-1, i, i+1.
  auto vertex_of = [&](const std::vector<double>& f, int i, double sign) {
    const double fm = sign * f[i - 1], f0 = sign * f[i], fp = sign * f[i + 1];
    const double den = fm - 2.0 * f0 + fp;
    return s[i] + (den < 0.0 ? std::clamp(0.5 * (fm - fp) / den, -0.5, 0.5) : 0.0) * kBandStep;
  };
  auto vertex = [&](int i, double sign) { return vertex_of(grad, i, sign); };
  const double s_pk = vertex(pk, pol);
  // The nearest strong opposite edge (a local maximum of -pol * grad) within band_max_px on
  // either side.
  std::array<int, 2> nb = {-1, -1};  // before, after the peak
  for (int i = d + 1; i < N - d - 1; ++i) {
    const double gi = -pol * grad[i];
    const double dist = std::abs(s[i] - s_pk);
    if (dist < 0.75 || dist > o.band_max_px || gi < 0.25 * std::abs(grad[pk])) continue;
    if (gi < -pol * grad[i - 1] || gi < -pol * grad[i + 1]) continue;
    int& slot = nb[s[i] > s_pk ? 1 : 0];
    if (slot < 0 || dist < std::abs(s[slot] - s_pk)) slot = i;
  }
  // A thin dark band outside the side (the side on a thin frame's inner edge: a poster's paper is
  // brighter than the wall, so its edge is the stronger one): its two peaks within band_thin_px
  // are the blur's, not the band's width, which the profile does not fix (a two-edge fit drifts
  // along it), but its darkest point lies at its centre (shifted towards the darker neighbour,
  // the wall): the side moves there, within half the band of the outline, whatever lies inside
  // (a poster's line of text near its bottom). A bright band outside the side (a tag's white
  // margin) is not the object's.
  // The side to the darkest point of a thin dark band between its peak and edge NB (false: none).
  // The darkest sample strictly between the side's peak and edge NB (-1: none).
  auto darkest_between = [&](int nb_i) {
    int ex = -1;
    for (int i = std::min(pk, nb_i) + 1; i < std::max(pk, nb_i); ++i)
      if (ex < 0 || y[i] < y[ex]) ex = i;
    return ex;
  };
  auto to_thin_dark_band = [&](int nb_i) {
    if (!(o.band_thin_px > 0.0) || nb_i < 0 ||
        std::abs(vertex(nb_i, -pol) - s_pk) > o.band_thin_px ||
        (nb_i > pk ? pol : -pol) >= 0.0)  // the profile rises into the band: bright
      return false;
    const int ex = darkest_between(nb_i);
    if (ex < 1 || ex > N - 2) return false;
    const double s_ex = vertex_of(y, ex, -1.0);
    // Half a thin band and the blur's push on its inner edge: at most 2 px.
    if (std::abs(s_ex - s_pk) > 2.0) return false;
    *offset = s_ex - s_pk;
    return true;
  };
  const int out = nb[n_inward ? 0 : 1], in = nb[n_inward ? 1 : 0];
  if (to_thin_dark_band(out)) return true;
  // A thin dark band inside the side (the side on a thin frame's outer edge, the weaker one: the
  // frame's inner edge, against the bright paper, pushes its peak outward by up to ~1 px) where the
  // two-edge model is refused: the band's darkest point, when it is thinner than the blur (its dip
  // below the darker neighbour at most band_thin_inside_max_dip of its depth below the brighter
  // one: a band as wide as the blur reaches its own grey) and the side's edge is a clear one.
  auto thin_inside = [&]() {
    if (!(o.band_thin_inside_max_dip > 0.0) || out >= 0 || in < 0 ||
        std::abs(grad[in]) <= std::abs(grad[pk]) ||
        std::abs(grad[pk]) < o.band_thin_inside_min_gradient)
      return false;
    const int ex = darkest_between(in);
    if (ex < 0) return false;
    const double darkest = std::min(y[pk], y[ex]);
    const double lo = std::min(y.front(), y.back()), hi = std::max(y.front(), y.back());
    const double dip = lo - darkest;
    return dip > 0.0 && dip <= o.band_thin_inside_max_dip * (hi - darkest) && to_thin_dark_band(in);
  };
  // None: no band. One on either side (a tag's black border between its white margin and its
  // white cells): their pushes oppose and the mix of cells along the side makes the profile no
  // model of it (the rendered room's small tags came out 0.1-0.2 px too large with it).
  if ((nb[0] < 0) == (nb[1] < 0)) return false;
  // The two edges in order of s, each step initialised from the grey halfway to its neighbours.
  const int main_edge = nb[0] >= 0 ? 1 : 0;
  const std::array<int, 2> idx = {main_edge == 1 ? nb[0] : pk, main_edge == 1 ? pk : nb[1]};
  constexpr int m = 2;
  Eigen::VectorXd th(2 * m + 2);
  th[0] = y[0];
  double prev = y[0];
  for (int e = 0; e < m; ++e) {
    const double next = e + 1 < m ? y[(idx[e] + idx[e + 1]) / 2] : y[N - 1];
    th[1 + e] = next - prev;
    th[1 + m + e] = idx[e] == pk ? s_pk : vertex(idx[e], -pol);
    prev = next;
  }
  th[2 * m + 1] = std::log(1.2);
  double rms = 0.0;
  const bool fitted = FitEdges(s, y, &th, &rms);
  const double sg = std::exp(th[2 * m + 1]);
  // A plausible fit: two clean steps (RMS residual within 5 % of the smaller step), a blur of
  // 0.85-1.5 px (the refinement's own smoothing is 1 px; a wider fitted blur means the profile is
  // something else, such as a cabinet's frame beside a faint inset line: moved 0.7 px inwards
  // without this), the edges keeping their polarities and order, and the side's edge moving by at
  // most 1.5 px.
  bool plausible =
      fitted && sg >= 0.85 && sg <= 1.5 && rms <= 0.05 * std::min(std::abs(th[1]), std::abs(th[2]));
  for (int e = 0; e < m && plausible; ++e)
    plausible =
        (e == main_edge ? pol : -pol) * th[1 + e] > 0.0 && (e == 0 || th[1 + m + e] > th[m + e]);
  const double move = th[1 + m + main_edge] - s_pk;
  if (!plausible || !(std::abs(move) <= 1.5)) return thin_inside();
  *offset = move;
  return true;
}

// The thin bands (band_max_px), side SKIP left as it is (a side moved off its shadow: the shadow
// is such a band).
void CorrectBandOffsets(const EdgeProbe& probe, int skip, Corners* corners) {
  if (!(probe.o.band_max_px > 0.0)) return;
  const Corners& c = *corners;
  std::array<Line, 4> lines;
  bool moved = false;
  const Vec2 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  for (int i = 0; i < 4; ++i) {
    const Vec2 P = c[(i + 3) % 4], Q = c[i];
    lines[i] = LineOf(MakeSeg(P, Q));
    double offset = 0.0;
    if (i != skip &&
        BandOffset(probe, P, Q, lines[i].n, lines[i].n.dot(centre - P) > 0.0, &offset)) {
      lines[i].c += offset;
      moved = true;
    }
  }
  if (!moved) return;
  Corners out;
  for (int i = 0; i < 4; ++i)
    if (!Intersect(lines[i], lines[(i + 1) % 4], &out[i])) return;
  if (IsConvex(out)) *corners = out;
}

}  // namespace

void CorrectSides(const EdgeProbe& probe, Corners* c) {
  const int shadow_side = MoveOntoFrameOutline(probe, c);
  CorrectBandOffsets(probe, shadow_side, c);
}

}  // namespace fsp::frontend::rect_internal
