// Stage 3 of the rectangle detector: junctions at segment ends, then quadrilateral hypotheses as
// 4-cycles of segments joined at junctions.
#include <algorithm>
#include <cmath>
#include <set>

#include "fsp/frontend/rect_geometry.h"
#include "rect_internal.h"

namespace fsp::frontend::rect_internal {
namespace {

// Which end of s the point x (on s's line) is a corner for, or -1. Beyond the end by up to gap,
// inside the segment by up to overshoot.
int JunctionEnd(const Seg& s, const Vec2& x, const RectDetectorOptions& o) {
  const double t = (x - s.a).dot(s.dir);
  const double beyond = t < 0.5 * s.len ? -t : t - s.len;  // > 0: x lies past that end
  const int end = t < 0.5 * s.len ? 0 : 1;
  if (beyond >= 0.0) return beyond <= o.junction_gap_frac * s.len + o.junction_slack_px ? end : -1;
  return -beyond <= o.junction_overshoot_frac * s.len + o.junction_slack_px ? end : -1;
}

// A curved segment meets another one with the piece at its nearer end (0: a, 1: b).
int NearEnd(const Seg& s1, const Seg& s2) {
  const double da = std::min((s1.a - s2.a).squaredNorm(), (s1.a - s2.b).squaredNorm());
  const double db = std::min((s1.b - s2.a).squaredNorm(), (s1.b - s2.b).squaredNorm());
  return da <= db ? 0 : 1;
}

}  // namespace

SegmentJunctions FindJunctions(const std::vector<Seg>& segs, const RectDetectorOptions& o,
                               const SegmentJunctions* known) {
  const int ns = static_cast<int>(segs.size());
  // With `known` (the junctions of segs[0, first)), only pairs with a segment from `first` on.
  const int first = known ? static_cast<int>(known->size()) : 0;
  SegmentJunctions ends = known ? *known : SegmentJunctions();
  ends.resize(ns);
  std::vector<Line> seg_lines(ns);
  for (int i = 0; i < ns; ++i) seg_lines[i] = LineOf(segs[i]);
  const double min_sin = std::sin(o.min_corner_angle_deg * M_PI / 180.0);
  // Compact copies of what the pair loop's cheap rejections read (the segments themselves carry
  // their polylines: a cache miss per pair).
  struct SegEnds {
    Vec2 a, b, dir;
    double len;
  };
  std::vector<SegEnds> se(ns);
  for (int i = 0; i < ns; ++i) se[i] = {segs[i].a, segs[i].b, segs[i].dir, segs[i].len};
  for (int i = 0; i < ns; ++i)
    for (int j = std::max(i + 1, first); j < ns; ++j) {
      const SegEnds &si = se[i], &sj = se[j];
      const double s = std::abs(si.dir.x() * sj.dir.y() - si.dir.y() * sj.dir.x());
      if (s < min_sin) continue;
      // Cheap rejection: the nearest endpoints must be within reach of both junction tolerances.
      const double reach = (o.junction_gap_frac + o.junction_overshoot_frac) * (si.len + sj.len) +
                           2.0 * o.junction_slack_px;
      const double dmin2 = std::min({(si.a - sj.a).squaredNorm(), (si.a - sj.b).squaredNorm(),
                                     (si.b - sj.a).squaredNorm(), (si.b - sj.b).squaredNorm()});
      if (dmin2 > reach * reach) continue;
      const int ni = segs[i].path.empty() ? -1 : NearEnd(segs[i], segs[j]);
      const int nj = segs[j].path.empty() ? -1 : NearEnd(segs[j], segs[i]);
      Vec2 x;
      if (!Intersect(ni < 0 ? seg_lines[i] : EndLine(segs[i], ni),
                     nj < 0 ? seg_lines[j] : EndLine(segs[j], nj), &x))
        continue;
      const int ei = JunctionEnd(segs[i], x, o);
      if (ei < 0 || (ni >= 0 && ei != ni)) continue;
      const int ej = JunctionEnd(segs[j], x, o);
      if (ej < 0 || (nj >= 0 && ej != nj)) continue;
      ends[i][ei].push_back({j, ej, x});
      ends[j][ej].push_back({i, ei, x});
    }
  return ends;
}

std::vector<Quad> FindQuads(const SegmentJunctions& ends, double min_side, int max_quads) {
  const int ns = static_cast<int>(ends.size());
  std::vector<Quad> quads;
  for (int a = 0; a < ns && static_cast<int>(quads.size()) < max_quads; ++a)
    for (const Junction& jb : ends[a][1]) {
      const int b = jb.seg;
      if (b <= a) continue;
      for (const Junction& jc : ends[b][1 - jb.end]) {
        const int c = jc.seg;
        if (c <= a || c == b) continue;
        for (const Junction& jd : ends[c][1 - jc.end]) {
          const int d = jd.seg;
          if (d <= a || d == b || d == c) continue;
          for (const Junction& ja : ends[d][1 - jd.end]) {
            if (ja.seg != a || ja.end != 0) continue;
            Quad q;
            q.c = {jb.x, jc.x, jd.x, ja.x};
            q.seg = {a, b, c, d};
            if (!IsConvex(q.c) || ShortestSide(q.c) < min_side) continue;
            quads.push_back(q);
          }
        }
      }
    }
  return quads;
}

std::vector<Quad> FindDoorQuads(const std::vector<Seg>& segs, const SegmentJunctions& ends,
                                const std::vector<Quad>& closed, const RectDetectorOptions& o,
                                int cols, int rows, double min_side) {
  std::vector<Quad> quads;
  // Three consecutive sides of the closed quads of the grouping: no door hypothesis on them (the
  // closed quad has a bottom with an edge).
  std::set<std::array<int, 3>> closed_triples;
  for (const Quad& q : closed)
    for (int i = 0; i < 4; ++i) {
      const int x = q.seg[i], y = q.seg[(i + 1) % 4], z = q.seg[(i + 2) % 4];
      closed_triples.insert({std::min(x, z), y, std::max(x, z)});
    }
  const double min_height = o.door_min_height_frac * rows;
  const double cos_vertical = std::cos(o.door_max_tilt_deg * M_PI / 180.0);
  auto vertical = [&](const Seg& s) { return std::abs(s.dir.y()) >= cos_vertical; };
  const int ns = static_cast<int>(segs.size());
  // A jamb piece lying on a longer jamb of the same polarity (the pieces of a jamb bridged by the
  // gap-tolerant merge) gives no hypothesis of its own: the longer one does.
  std::vector<char> jamb(ns, 0);
  for (int i = 0; i < ns; ++i)
    jamb[i] = segs[i].path.empty() && vertical(segs[i]) && segs[i].len >= min_height;
  const double cos_merge = std::cos(o.merge_angle_deg * M_PI / 180.0);
  for (int i = 0; i < ns; ++i)
    for (int j = 0; j < ns && jamb[i]; ++j) {
      const Seg &p = segs[i], &l = segs[j];
      if (j == i || !jamb[j] || l.len <= p.len || p.dir.dot(l.dir) < cos_merge) continue;
      const Line ll = LineOf(l);
      const double ta = (p.a - l.a).dot(l.dir), tb = (p.b - l.a).dot(l.dir);
      if (std::abs(ll.Dist(p.a)) <= o.merge_line_px && std::abs(ll.Dist(p.b)) <= o.merge_line_px &&
          std::min(ta, tb) >= -o.junction_slack_px &&
          std::max(ta, tb) <= l.len + o.junction_slack_px)
        jamb[i] = 2;  // covered: kept as a segment, not as a jamb
    }
  // A door from a lintel with a jamb hanging down from each end: `t` is the lintel (its segment),
  // jl and jr the jambs' junctions with it at the lintel's two ends.
  auto door = [&](int t, const Junction& jl, const Junction& jr) {
    if (jl.seg == jr.seg) return;
    // Left and right jambs hanging down from the lintel's two ends: long, near-vertical, their
    // free ends below the junctions.
    const Seg& top = segs[t];
    const Seg& a = segs[jl.seg];
    const Seg& b = segs[jr.seg];
    if (jamb[jl.seg] != 1 || jamb[jr.seg] != 1 ||
        closed_triples.count({std::min(jl.seg, jr.seg), t, std::max(jl.seg, jr.seg)}))
      return;
    const Vec2 fa = jl.end == 0 ? a.b : a.a;  // free ends
    const Vec2 fb = jr.end == 0 ? b.b : b.a;
    if (fa.y() - jl.x.y() < min_height || fb.y() - jr.x.y() < min_height) return;
    // The bottom: the line through the free ends (refinement looks for its edge there and
    // keeps that line when there is none: a door's bottom in shadow, on a dark floor) when it
    // is within `door_bottom_max_deg` of the lintel's direction (perspective tilts them
    // apart); and when the free ends are not level with each other (the jambs' edges fade out
    // at different heights), also the line parallel to the lintel through the lower free end.
    const Vec2 ut = top.dir;
    const Vec2 ub = (fb - fa).normalized();
    const double sin_bottom = std::abs(ub.x() * ut.y() - ub.y() * ut.x());
    auto add = [&](const Vec2& ca, const Vec2& cb) {
      Quad q;
      q.c = {jl.x, jr.x, cb, ca};
      q.seg = {jl.seg, t, jr.seg, -1};
      q.weak_side = 3;
      if (!IsConvex(q.c) || ShortestSide(q.c) < min_side) return;
      // Near-duplicates (parallel lintel lines, jambs' ends a pixel apart) are refined once.
      const double tol = std::max(2.0, o.duplicate_corner_frac * ShortestSide(q.c));
      for (const Quad& d : quads) {
        bool same = true;
        for (int i = 0; i < 4 && same; ++i) same = (d.c[i] - q.c[i]).norm() <= tol;
        if (same) return;
      }
      quads.push_back(q);
    };
    if (sin_bottom <= std::sin(o.door_bottom_max_deg * M_PI / 180.0)) add(fa, fb);
    if (sin_bottom > std::sin(M_PI / 180.0)) {
      Line bottom;
      bottom.n = Vec2(-ut.y(), ut.x());
      bottom.c = bottom.n.dot(fa.y() > fb.y() ? fa : fb);
      Vec2 ca, cb;
      if (Intersect(LineOf(a), bottom, &ca) && Intersect(LineOf(b), bottom, &cb)) add(ca, cb);
    }
  };
  // Lintels: near-horizontal straight segments. A lintel broken by an occluder (a branch, a lamp,
  // a sign in front of it) is two collinear pieces (same polarity, within the merge tolerances)
  // with a gap of up to `door_jamb_gap_frac` of the diagonal between them, as for jambs: the left
  // jamb meets the first piece, the right jamb the second. (Merging all collinear pieces with that
  // gap instead joins a door's lintel with the top of a window beside it, whose end is no corner.)
  auto jamb_at = [&](int t, int e) {
    for (const Junction& j : ends[t][e])
      if (jamb[j.seg] == 1) return true;
    return false;
  };
  std::vector<int> lintels;
  for (int t = 0; t < ns; ++t)
    if (std::abs(segs[t].dir.x()) >= std::abs(segs[t].dir.y()) && (jamb_at(t, 0) || jamb_at(t, 1)))
      lintels.push_back(t);
  const double max_gap = o.door_jamb_gap_frac * std::hypot(cols, rows);
  for (const int t : lintels) {
    if (!jamb_at(t, 0)) continue;
    for (const int t2 : lintels) {
      if (!jamb_at(t2, 1)) continue;
      if (t2 != t) {
        // t2 continues t beyond its end b, on its line (straight pieces only).
        const Seg &s1 = segs[t], &s2 = segs[t2];
        if (!s1.path.empty() || !s2.path.empty()) continue;
        if (s1.dir.dot(s2.dir) < cos_merge) continue;
        const double gap = (s2.a - s1.b).dot(s1.dir);
        if (gap < -o.junction_slack_px || gap > max_gap) continue;
        const Line l1 = LineOf(s1), l2 = LineOf(s2);
        if (std::abs(l1.Dist(s2.a)) > o.merge_line_px || std::abs(l2.Dist(s1.b)) > o.merge_line_px)
          continue;
      }
      const int lintel = t2 == t || segs[t].len >= segs[t2].len ? t : t2;
      for (const Junction& jl : ends[t][0])
        for (const Junction& jr : ends[t2][1]) {
          door(lintel, jl, jr);
          if (static_cast<int>(quads.size()) >= o.max_hypotheses) return quads;
        }
    }
  }
  return quads;
}

}  // namespace fsp::frontend::rect_internal
