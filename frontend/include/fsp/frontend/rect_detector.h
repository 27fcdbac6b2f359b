// Rectangle detector: finds the images of 3-D rectangles (doors, windows, cabinets, posters,
// boards) with sub-pixel corners.
//
// Pipeline (each stage is timed, see RectDetector::Result::times):
//  1. "edges":    Sobel gradients and Canny edges; the hysteresis thresholds come from the image's
//  own
//                 gradient statistics (a noise estimate from the median gradient magnitude), not
//                 from fixed grey-level values.
//  2. "segments": Canny pixels linked into 8-connected chains, chains split into straight pieces
//                 (recursive split at the farthest pixel), each piece fitted by least squares;
//                 endpoints undistorted when a calibration is given; collinear pieces merged.
//                 (cv::ximgproc::FastLineDetector does the same but took ~20 ms per 640x480 frame.)
//  3. "group":    quadrilateral hypotheses: 4 segments joined at L-junctions (intersection close to
//  an
//                 endpoint of both) that close into a convex quadrilateral.
//  4. "refine":   per side, sub-pixel edge points found along the side's normal (1-D gradient peak
//  in the
//                 DISTORTED image, then undistorted), a RANSAC line fit and a gradient-weighted
//                 total least-squares refit on the inliers; corners = intersections of adjacent
//                 sides.
//  5. "verify":   rectangle test with K (Zhang-He: the 3-D edges of a true rectangle are
//  perpendicular),
//                 every corner inside the image (`max_corner_outside_px`; a quad just cut off by
//                 the border is kept as a container, see `container_outside_frac`), every corner
//                 an L-corner (no side runs on past it, every side reaches it:
//                 `max_side_continuation`, `min_corner_reach`), edge support score, class guess.
//  6. "nms":      duplicates (same corners within a tolerance) keep the best score; nesting rule
//  below.
//
// Nesting rule (a window frame and its pane, a thick door frame's two outlines): when quad B lies
// inside quad A and every corner of B is within `nest_corner_frac` x (A's shortest side) of A's
// matching corner, B is the inner outline of the same object and is dropped: the OUTER outline is
// reported (the object's full extent), unless its edge support is clearly lower
// (`nest_score_margin`). Exception, the bright margin rule (`prefer_inner_of_bright_margin`): when
// the ring between the two outlines is plain and brighter than both the plain strip inside B and
// the surroundings of A, the ring is a margin (an AprilTag's white border, a print's mat) and B,
// the object proper (the tag's black square), is reported. When nested quads share two adjacent
// corners (a board and the quad closed by the row of tags below its top edge; a window and its
// lower pane) they are alternatives for one object and the better-scoring one is kept; so are
// near-concentric quads that cross (one side from each of two parallel outlines). Finally, with
// `drop_contained` (default), any rectangle inside another detection is dropped (one object per
// outer rectangle: panes, door panels, tag pattern squares); without it, rectangles inside
// rectangles (a poster on a door) are kept as objects of their own.
//
// Pixel thresholds are either relative (a fraction of a segment's length or of the image diagonal)
// or tied to the edge profile (fractions of a pixel); none is tuned to one camera.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/common/camera.h"
#include "fsp/frontend/detection.h"

namespace fsp::frontend {

// Options of RectDetector (see the class comment).
struct RectDetectorOptions {
  // --- 0. resolution ---
  // Images whose longer side is at least twice this [px] are detected on a level reduced by the
  // largest integer factor k that keeps the longer side >= this (area averaging; the level's
  // longer side is then in [detect_long_side, 2 x detect_long_side)), and the corners of each
  // detection are refined on the full-resolution image (the polarity of each side as found on the
  // level, a search of +-max(search_px, 1.5 k) px). A 12-megapixel photo is detected like a
  // 640 x 480 frame: the fractions of the image below then mean the same thing at every resolution,
  // the pixel values (edge blur, search widths, slacks) are level pixels, and the time does not
  // grow with the pixel count. 0 detects at full resolution.
  int detect_long_side = 400;
  // With a calibration (a video camera), the level is also kept fine enough for the smallest
  // rectangle reported (`min_side_px`) to be at least this long there [level px]: a 1280 x 720
  // frame is detected at 640 x 360 instead of 427 x 240, where 30-45 px switch plates were 10-15
  // level px, shorter than the edge stage's pieces and the refinement's corner margins allow
  // (DM-VIO walk's labelled frames: see min_side_px). 0: detect_long_side alone.
  double min_level_side_px = 16.0;
  // Texture hypotheses (with a calibration only): the gradient magnitude (|dx| + |dy| of the
  // smoothed image) area-averaged by this factor, and the edge, segment and grouping stages run on
  // that map; its quads (corners scaled to full resolution) join the hypotheses, every side
  // searched for edges of either polarity. A rectangle whose interior is a fine pattern (a
  // checkerboard: its sides alternate between the outer edge at white squares and the margin's
  // inner edge of the opposite polarity at black ones, broken at every square) is one bright
  // block there with a clean outline. 0 switches this off.
  int texture_level = 4;
  // Search half-width [px] of a coarse refinement of a texture hypothesis that the usual one
  // (search_px) does not refine: its corners, scaled up from the averaged map, are up to ~4 px
  // off; the usual pass follows the coarse one. (Coarse first for every texture hypothesis lost
  // the board where the usual pass alone finds it: the wide search also reaches the pattern's
  // own edges.) Wider reaches the smeared edges of a motion-blurred poster: its tracks restarted
  // in the rendered blur clip (id switches 6 at 6 px, 1 at 5 px, none at 4.5 px or without).
  // 0: the usual pass only. See the front end's README for the measurements.
  double texture_search_px = 4.5;
  // Side ends of a texture hypothesis that may fall short of their corner in the corner reach test
  // (any corner, any size; see reach_failures_any_corner): a checkerboard's dark corner square
  // next to its thin white margin has the stronger edge ~2 px inside the outline. In-flight EuRoC
  // frames: with 1, the board in 6 of 10 frames; with 2, in 7.
  int texture_reach_failures_any_corner = 2;

  // --- 1. edges ---
  // High Canny threshold as a multiple of the gradient noise level, estimated as the median Sobel
  // magnitude / 1.177 (the Rayleigh median for pure noise). Lower finds fainter edges but more
  // clutter.
  double canny_noise_multiple = 5.0;
  // Floor of the high threshold as a grey-level step [grey levels, 8-bit]: edges weaker than this
  // step are never seeds even in a perfectly clean image. Lower finds low-contrast objects and more
  // clutter.
  double min_edge_contrast = 8.0;
  // Low (hysteresis) threshold as a fraction of the high one. Lower links edges across weak parts.
  double canny_low_ratio = 0.4;

  // --- 2. segments ---
  // Shortest segment kept [fraction of the image diagonal]. Longer ignores small clutter and small
  // rectangles; shorter costs time in grouping.
  double min_segment_frac = 0.02;
  // Largest distance of an edge pixel from the chord of its piece before the chain is split [px].
  double segment_fit_px = 1.414;
  // Collinear merge of pieces with the same polarity (bright side on the same side): max angle
  // [deg] and max endpoint-to-line distance [px] between two pieces, and max gap between them
  // [fraction of the image diagonal]. A larger gap merges pieces broken by crossings or occlusion
  // but also joins the collinear edges of neighbouring objects (a row of windows).
  double merge_angle_deg = 3.0;
  double merge_line_px = 2.0;
  double merge_gap_frac = 0.04;
  // Bridged sides: collinear segments of either polarity with gaps of up to this [fraction of the
  // image diagonal] are also joined into one segment, kept beside the pieces for grouping only (a
  // side whose background changes along it: a panel before a bright wall above and a dark
  // radiator below; a side broken by clutter crossing it). Refinement searches such a side for
  // edges of either polarity. 0 switches this off. Without a calibration
  // `uncalibrated_bridge_gap_frac` is used instead (off: on the real door photos it found no door
  // more and one extra rectangle more, and the sudoku page's top side closed on a line of text).
  double bridge_gap_frac = 0.08;
  double uncalibrated_bridge_gap_frac = 0.0;
  // Shortest bridged side kept [fraction of the image diagonal]: each one costs grouping time,
  // and short sides are seldom broken.
  double bridge_min_frac = 0.1;
  // Shortest segment a bridged side is made of [fraction of the image diagonal]: the pieces of
  // motion-blurred edges stay apart (bridging them in the rendered blur clip found the blurred
  // poster in more frames, whose tracks then restarted: 5 id switches against 2).
  double bridge_min_piece_frac = 0.06;
  // Slowly bending edges (curled paper): straight pieces that continue each other (the end of one
  // at the start of the next, same polarity) with directions within `curved_step_deg` of each
  // other also form one curved segment when their first and last directions differ by at most
  // `curved_total_deg`; such a side is sampled along its pieces and its corners come from the
  // lines fitted to its end pieces. 0 switches this off.
  double curved_step_deg = 6.0;
  double curved_total_deg = 15.0;
  // Shortest curved segment [fraction of the image diagonal]: short chains bend too little to
  // matter, and each one costs grouping and refinement time.
  double curved_min_frac = 0.15;
  // Stretch of a curved side next to each corner that the corner's line is fitted to [fraction of
  // the side's length, at least 30 px].
  double curved_corner_frac = 0.1;

  // --- 3. grouping ---
  // Shortest side of a rectangle [fraction of the image diagonal]; 0.04 is ~32 px at 640x480.
  double min_side_frac = 0.04;
  // With a calibration (a video camera: what it can detect depends on an object's size in pixels,
  // not on its share of the frame), the shortest side is at most this [px of the full-resolution
  // image], and the shortest segment (min_segment_frac) at most min_segment_frac / min_side_frac
  // of it. 32 is min_side_frac at 640 x 480 (the rendered room, EuRoC: unchanged there); at
  // 1280 x 720 min_side_frac alone asked for 59 px, more than every switch plate and the sheet of
  // paper of the DM-VIO walk's labelled frames (30-68 px). 0: the fractions alone (photographs
  // are detected without a calibration and keep them). 32 is the value measured
  // (frontend/README.md, "Small rectangles on video").
  double min_side_px = 32.0;
  // Smallest / largest image angle between adjacent sides [deg]. Perspective bends 90 deg a lot.
  double min_corner_angle_deg = 25.0;
  // A junction of two segments: their intersection may lie beyond a segment's end (the side's edge
  // fades or is occluded near the corner) by up to this fraction of the segment's length...
  double junction_gap_frac = 0.3;
  // ...or inside the segment (the segment runs past the corner) by this fraction. Small on purpose:
  // crossing lines (grids, frames that run on) are not corners, or every cell of a grid would be a
  // rectangle.
  double junction_overshoot_frac = 0.08;
  // Absolute slack of both junction tests [px]: segments stop a pixel or two short of real corners.
  double junction_slack_px = 3.0;
  // Door hypotheses (only where the door rule applies, see door_reach_failures_allowed): a
  // near-horizontal lintel segment with a jamb segment hanging down from each of its ends (within
  // `door_max_tilt_deg` of the image vertical, at least `door_min_height_frac` of the image height
  // long and below the lintel), closed by the line through the jambs' lower ends even when no edge
  // is found there (a door's bottom in shadow, on a dark floor or carpet): three sides of a door
  // are enough.
  bool door_hypotheses = true;
  double door_max_tilt_deg = 20.0;
  double door_min_height_frac = 0.25;
  // Largest angle between a door hypothesis' bottom through the jambs' lower ends and its lintel
  // [deg] (perspective); when those ends are not level, a bottom parallel to the lintel through
  // the lower end is also tried.
  double door_bottom_max_deg = 30.0;
  // Largest gap [fraction of the image diagonal] bridged between collinear near-vertical pieces of
  // a jamb (a handle, hinges, a sign, a shadow across the side) for the door hypotheses, and
  // between two collinear pieces of a lintel (a branch or a lamp in front of it) whose ends the
  // two jambs meet.
  double door_jamb_gap_frac = 0.15;
  // Cap on hypotheses per image (bounds the time on heavy clutter).
  int max_hypotheses = 3000;

  // --- 4. refinement ---
  // Half-length of the 1-D edge search along a side's normal [px]. Must cover the segment's error
  // (about one pixel) but stay below the distance to neighbouring parallel edges.
  double search_px = 2.5;
  // Search only edges of the polarity of the side's segment (brighter on the same side). Keeps a
  // side on the edge it was found on when a thin line or groove has two edges within the search.
  bool polarity_from_segment = true;
  // Sample spacing along the normal [px] (bilinear interpolation).
  double search_step_px = 0.5;
  // Edge samples per side (fewer: faster, noisier lines).
  int samples_per_side = 40;
  // Part of each side next to its corners that is not sampled [fraction of the side], where the
  // other side's edge and corner rounding disturb the profile.
  double corner_margin_frac = 0.08;
  // RANSAC inlier distance [px] and number of two-point draws per side.
  double ransac_inlier_px = 0.75;
  int ransac_iterations = 24;
  // Seed of the RANSAC generator (results are deterministic for a given seed).
  uint32_t seed = 1;
  // A side counts as bent when lines fitted to its halves leave its global line by more than this
  // at the corners [px]; each corner then comes from the half-lines next to it (robust to bent
  // paper and residual distortion, ~1.4x noisier than the global line on a straight side).
  double bend_px = 0.35;
  // Least fraction of a side's samples that must be inliers of its line (edge support). Higher
  // rejects partly occluded rectangles.
  double min_side_support = 0.5;
  // Frame outline: a framed object (a dark frame round a lighter panel: a cabinet, a door) whose
  // frame meets a background of nearly its own grey along one side (a dark frame on a dark floor)
  // shows no edge there, and that side is found on the frame's inner edge. Recognised when three
  // sides' inside is darker (or brighter) than their outside and the fourth's the opposite, with
  // the contrast of a frame edge, and the opposite side shows the frame: a band of one grey from
  // its outline to an edge of the fourth side's polarity, within this fraction of the quad's
  // shortest side. The fourth side is then moved out by the band's width there (scaled by the two
  // sides' length ratio, the perspective) when the band's grey lies outside it, and onto an edge
  // found there. The same odd side of a bright object with no frame on the opposite side is the
  // outer edge of its shadow (a wall plate's): it moves in onto the object's edge, the strongest
  // rise to the object's grey within this fraction, and the thin-band rules leave it there. 0: off.
  double frame_band_max_frac = 0.2;
  // Thin bands: a side whose edge has an edge of the opposite polarity within this distance on one
  // side of it (a poster's thin dark frame, a door's architrave line) is found too far from the
  // band, because the blur pushes the two edges' gradient peaks apart (by up to ~1.5 px for a 1 px
  // band). A model of the two blurred edges is fitted to the side's median profile across it and
  // the side is moved from the peak to the model's edge. 0: off.
  double band_max_px = 4.0;
  // A band outside the side (the side found on a thin frame's inner edge) whose two edges' peaks
  // lie within this distance: the peaks are the blur's, the band's width is not known, and the
  // side moves to the band's centre (its grey's extremum), within half the band of the outline.
  // 0: off (the two-edge model instead, which keeps the side on the inner edge).
  double band_thin_px = 3.5;
  // A dark band inside the side (the side on a thin frame's outer edge, pushed outward by the
  // frame's stronger inner edge) whose peaks lie within band_thin_px, where the two-edge model is
  // refused: the side moves to the band's darkest point when the band is thinner than the blur
  // (its dip below the darker neighbour at most this fraction of its depth below the brighter one)
  // and the side's gradient is at least band_thin_inside_min_gradient [grey levels / px].
  // 0: off.
  double band_thin_inside_max_dip = 0.6;
  double band_thin_inside_min_gradient = 8.0;
  // T-junction test: a side's edge must end at its corners. Edge points are searched on the side's
  // line extended past each corner, from `continuation_start_px` (clear of the other side's
  // blurred edge) over `continuation_frac` x the side's length; a point counts when its gradient
  // peak has the side's polarity, at least half the side's median gradient and lies on the
  // extended line. When more than `max_side_continuation` of the points inside the image count,
  // the object runs on past the "corner" and the quad (a cut-off door closed by a panel groove, a
  // window cut by the image border closed by a mullion) is rejected. 1 switches the test off;
  // lower also rejects objects whose side is collinear with a neighbouring edge of the same
  // polarity (a door's bottom on a floor line as dark as the door frame).
  double max_side_continuation = 0.3;
  double continuation_start_px = 4.0;
  double continuation_frac = 0.3;
  // Consecutive continuation samples (2 px apart, at most 12 over `continuation_frac` x the side:
  // ~10 px apart on a 400 px side) form one run only when the edge is also found between them at
  // least every this many px [px]: a line running on is continuous; the ends of text strokes or
  // texture that line up with the side are not. Smaller is stricter (and costs more probes); 0
  // switches the in-between check off.
  double continuation_step_px = 3.0;
  // Union test: when two opposite sides of a quad both lack their edge over the same stretch
  // across the object, of at least this fraction of their length, between stretches where both
  // have it, the quad joins two objects side by side by their collinear sides (two posters with
  // wall between them: the wall has no edge there); it is not reported. A window's frame runs on
  // across its mullion, a door's across its panels. 0 switches the test off.
  double union_gap_frac = 0.05;
  // Corner reach test: each side's edge must reach its corners. Points on the side's line from
  // `reach_start_px` to max(`reach_min_px`, `reach_frac` x the side's length) from each corner are
  // searched like the continuation; fewer than `min_corner_reach` of them on the edge rejects the
  // quad (its corner lies beyond where the side's edge ends: a tag's black square closed on one
  // side by the outer edge of its white margin). 0 switches the test off.
  double min_corner_reach = 0.5;
  // The corner reach test also counts edge points of the polarity opposite to the side's: where
  // the background changes along a side (a panel before a bright wall above and a dark radiator
  // below, a checkerboard's border squares) the stretch next to a corner may have the other
  // polarity. A line running on across a plain margin (the tag case above) has no edge of either.
  // Without a calibration `uncalibrated_reach_either_polarity` is used instead (off: the sudoku
  // page's outline closed by the sheet's edge beyond the printed square passed with it).
  bool reach_either_polarity = true;
  bool uncalibrated_reach_either_polarity = false;
  // Side ends that may fail the corner reach test, and only the two ends at the quad's lowest
  // corner in the image (a door's bottom in shadow or on a floor line). 0: every side reaches every
  // corner. Without a calibration `uncalibrated_reach_failures_allowed` is used instead.
  int reach_failures_allowed = 0;
  // Besides those, side ends at any corner that may fail the corner reach test: one lets a side
  // whose edge fades over its last pixels (a grey panel's corner against a grey floor, a foot or
  // bracket at the corner, a checkerboard's black corner square) through, while a quad closed by
  // a line beyond the object still fails (both sides meeting that line run on across a plain
  // margin: two short ends). Without a calibration `uncalibrated_reach_failures_any_corner` is used
  // instead.
  int reach_failures_any_corner = 1;
  int uncalibrated_reach_failures_any_corner = 0;
  // ...and only on quads whose shortest side is at least this [fraction of the image diagonal; 2 x
  // min_side_frac] and that are clear of the image border (see HasTJunction in rect_verify.cc).
  double any_corner_min_side_frac = 0.08;
  // A door-shaped quad (metric height / width in [door_min_aspect, door_max_aspect]; 0 switches
  // this off) may have up to this many side ends fail the corner reach test, at any corner: a door
  // leaf's edges fade into its frame where the leaf and frame have the same colour, into the
  // shadow at its bottom, or stop short at hinges. Without a calibration
  // `uncalibrated_door_reach_failures_allowed` is used instead.
  int door_reach_failures_allowed = 0;
  int uncalibrated_door_reach_failures_allowed = 8;
  double door_min_aspect = 1.25;
  double door_max_aspect = 3.5;
  // A quad that passed only by the door rule or by a short end at any corner
  // (`reach_failures_any_corner`) and overlaps a quad that passed without it (or scores higher) by
  // more than this fraction of the smaller area (neither containing the other) is dropped (a
  // printed grid's column closed by a line below the grid crosses the grid's outline; a poster and
  // the cabinet below it joined by their collinear left sides cross both).
  double door_rule_max_overlap = 0.3;
  double reach_start_px = 2.0;
  double reach_min_px = 6.0;
  double reach_frac = 0.1;

  // --- 5. verification ---
  // Largest |cos| of the 3-D angle between adjacent sides (Zhang-He); 0.2 is 90 +- 11.5 deg.
  // Smaller rejects more non-rectangles but also true rectangles with noisy corners or a wrong K.
  double max_abs_cos = 0.2;
  // Corner error allowed in the rectangle test [px of the detection level]: the |cos| tested is
  // the smallest one reachable to first order by moving each corner up to this far (the refined
  // corners; twice this for the hypotheses' pre-test). A small quad's 3-D angle is ill-conditioned
  // (a pixel moves its sides' vanishing points a lot): the DM-VIO walk's hand-labelled switch
  // plates (30-45 px, labels good to 2-3 px) have |cos| up to 0.46, the monitors (170-500 px) at
  // most 0.05. 0: the plain test, which rejects small rectangles seen nearly head-on. 0.5 is the
  // value measured (frontend/README.md, "Small rectangles on video").
  double rectangle_corner_px = 0.5;
  // Largest metric aspect ratio (long side / short side) accepted.
  double max_aspect = 8.0;
  // Horizontal field of view [deg] assumed for K when no calibration is given (corner order with a
  // gravity direction; the rectangle test with focal_prior_steps = 0).
  double assumed_hfov_deg = 60.0;
  // Without a calibration the focal length is unknown (phones and consumer cameras: ~0.7-1.2 x the
  // longer image side): the rectangle test passes when it passes for some focal length of
  // `focal_prior_steps` values spaced geometrically over [focal_prior_min, focal_prior_max] x the
  // longer image side (principal point at the centre), its metric aspect taken at that focal
  // length. A trapezoid seen in perspective (a door from the side) passes at the focal length of
  // the camera; a quad that is no rectangle at any plausible focal length does not. With a
  // calibration its K alone is used.
  // Without a calibration (still photos of unknown cameras) the containers use this instead of
  // container_outside_frac. Measured on the real door photos of tests/frontend/test_doors.cc: a
  // quad closed by a floor or ceiling line just out of view contains the door and hid it (7 / 35
  // doors found with 0.25, 14 with 0). (Relaxing the L-corner tests as well finds more doors, 17
  // with a corner reach of 0.25 and 22 with none, but lets the sudoku page's border-line variants
  // through: its corners are then 37 px off.) With a calibration nothing changes.
  double uncalibrated_container_outside_frac = 0.0;
  // Without a calibration: reach_failures_allowed (2: the lowest corner need not be reached;
  // doors_dev 15 / 35 against 14, the sudoku page unchanged; any corner, 1 end: 16 / 35 but a
  // second sudoku detection).
  int uncalibrated_reach_failures_allowed = 2;
  double focal_prior_min = 0.6;
  double focal_prior_max = 1.6;
  int focal_prior_steps = 7;
  // Largest distance of a corner outside the image [px, distorted]. A corner outside is not
  // observed: the sides that meet there run out of view and the quad is usually closed by another
  // line (a cut-off door closed by its panel groove). Larger keeps such guesses.
  double max_corner_outside_px = 1.0;
  // A rectangle with a corner outside the image by at most this fraction of its shortest side is
  // not reported but still suppresses the rectangles inside it (with `drop_contained`): a door
  // whose bottom corners are just out of view hides its leaf and panels. 0 switches this off.
  double container_outside_frac = 0.25;
  // Guess classes (tag, door, window, cabinet, poster) from shape, brightness and texture.
  bool guess_class = true;

  // --- 6. suppression ---
  // Duplicates: largest corner distance [fraction of the shorter shortest side, min 2 px].
  double duplicate_corner_frac = 0.03;
  // Nesting (see above): corner distance [fraction of the outer quad's shortest side].
  double nest_corner_frac = 0.25;
  // ...but an outer outline whose score is lower than the inner one's by more than this keeps the
  // inner one (the side face of a thick board or box seen at an angle is not part of the
  // rectangle).
  double nest_score_margin = 0.05;
  // Bright margin rule (fiducials: AprilTags, ArUco, checkerboard quiet zones; a mat around a
  // print): when two nested near-concentric outlines enclose a plain ring that is brighter than
  // both the plain strip just inside the inner outline and the surroundings outside the outer one,
  // the ring is a margin around the object, not part of it: the INNER outline (a tag's black
  // square) is reported whatever the scores. Frames darker than their content (doors, windows,
  // posters, a board's dark backdrop) never qualify, so the outer-outline rule above still applies
  // to them.
  bool prefer_inner_of_bright_margin = true;
  // The ring must be brighter than the strip inside the inner outline by at least this [grey
  // levels, 8-bit, on the sigma 1 px smoothed image]; the surroundings need only be darker by
  // `min_edge_contrast`. Lower lets low-contrast frames count as margins.
  double margin_min_contrast = 40.0;
  // Plainness: the grey-level standard deviation along the ring and along the inner strip must not
  // exceed this fraction of the ring-to-inner contrast. Higher accepts textured rings (a tag grid's
  // alternating tags and gaps are rejected by this: a calibration board keeps its outer outline).
  double margin_max_texture = 0.25;
  // Narrowest ring the rule is applied to [px]; thinner rings cannot be sampled apart from the
  // blurred edges (then the outer outline wins as before).
  double margin_min_width_px = 2.5;
  // Quads down to this fraction of the minimum side (`min_side_frac`) are also found, never
  // reported, only to recognise bright margins around objects too small to report: such a margin
  // outline (a small tag's white border) is dropped too. 0.75 covers tag36h11 (black square = 0.8
  // x the margin outline); lower costs grouping time, 1 switches this off.
  double margin_probe_frac = 0.75;
  // Report one object per outer rectangle: quads lying inside another detection (window panes, door
  // panels, the pattern squares of a tag) are dropped. False keeps them (a poster on a door becomes
  // its own object again, but so does every pane).
  bool drop_contained = true;
  // Door leaf rule: of nested outlines, a door-shaped inner one (see door_min_aspect) is the door
  // leaf and the outer ones its frame, architrave or the wall opening: the leaf is reported (unless
  // its score is lower by more than `nest_score_margin`), and so is a door-shaped quad inside a
  // non-concentric outline (a frame with a transom or side light) when it covers at least
  // `door_leaf_min_area_frac` of that outline's area (a door's panels cover less).
  // With a calibration off by default: the rendered room's doors (the simulator's ground truth)
  // are their outer outline, which the rendered-frame tests pin. Without a calibration (photos)
  // `uncalibrated_prefer_door_leaf` is used instead.
  bool prefer_door_leaf = false;
  bool uncalibrated_prefer_door_leaf = true;
  double door_leaf_min_area_frac = 0.5;
  // At most this many detections, best score first (0: no limit).
  int max_detections = 0;

  // --- diagnostics ---
  // Fill the Result's debug vectors (segment_ends, hypothesis_quads, verified_quads). Off: they
  // stay empty, which saves copying up to `max_hypotheses` quads per call; the detections are the
  // same either way.
  bool debug = false;

  bool Check(std::string* why) const;
};

class RectDetector {
 public:
  using Options = RectDetectorOptions;

  // Diagnostics of one call.
  struct Result {
    std::vector<Detection> detections;  // best score first
    StageTimes times;                   // edges, segments, group, refine, verify, nms
    int segments = 0;                   // after merging
    int hypotheses = 0;                 // quads from grouping
    int refined = 0;                    // quads that survived refinement
    // Only with Options::debug (else empty), in undistorted pixels of the detection level (of a
    // reduced level when the image is detected on one: see detect_long_side):
    std::vector<std::pair<Vec2, Vec2>> segment_ends;  // merged segments
    std::vector<Corners> hypothesis_quads;            // grouping's quads
    std::vector<std::pair<Corners, double>>
        verified_quads;  // before suppression, with score (incl. margin probes)
    double canny_low = 0.0, canny_high = 0.0;  // thresholds used (Sobel magnitude units)
  };

  explicit RectDetector(Options options = Options());

  // Detects rectangles in an 8-bit grey image (CV_8UC1; FSP_CHECKed). `camera` (optional) gives K
  // and the distortion: edge points are undistorted so sides are straight lines; its size must
  // match the image. `gravity_C` (optional) is the gravity direction in the camera frame (any
  // length) used to order the corners (bottom = along gravity); without it the image's +v is down.
  // `ignore` (optional): convex quadrilaterals in image pixels whose edges are dropped before
  // anything is built from them (the front end passes the insides of the objects it tracks, so
  // their panes, panels and printed shapes cost no hypotheses while their outlines are found).
  Result Detect(const cv::Mat& gray, const PinholeRadtan* camera = nullptr,
                const Vec3* gravity_C = nullptr,
                const std::vector<Corners>* ignore = nullptr) const;

  const Options& options() const { return options_; }

 private:
  Options options_;
};

}  // namespace fsp::frontend
