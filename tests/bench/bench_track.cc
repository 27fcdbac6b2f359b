// Rectangle tracking benchmark on rendered clips (e.g. assets/scenes/clip_zoom_roll.yaml rendered
// by `fsp render SCENE --out DIR`): every candidate tracker starts each object on the object's
// first fully visible frame from its ground-truth corners, then runs on every later frame without
// help.
//
//   bench_track [--per-object] CLIP_DIR [CLIP_DIR ...]
//
// Prints a markdown table to stdout, one row per (tracker, clip), the frames of all the clip's
// objects pooled (--per-object: also one row per object):
//   success 2px  frames where the ground truth is fully visible and all 4 reported corners are
//                within 2 px of the true ones (a box tracker's corners are its box corners, so it
//                can only succeed while the object is close to an upright rectangle), in % of the
//                fully visible frames after the start frame (no report counts as a failure);
//   success IoU  the same frames scored by box IoU >= 0.5 between the reported quad's bounding
//                box and the true corners' bounding box (the usual box-tracker criterion);
//   median px    median, over those frames with a report, of the mean distance of the 4 corners;
//   out of view  frames with a report while the object is absent (no ground-truth row: out of
//                the image or behind the camera); a box there is a false track;
//   ms/frame     median over frames of Track() wall time divided by the number of started objects.
// Frames where the object is only partly visible are not scored. Single thread
// (cv::setNumThreads(1)).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/tracking.hpp>
#include <opencv2/tracking/tracking_legacy.hpp>

#include "fsp/common/dataset.h"
#include "fsp/common/error.h"
#include "fsp/common/observations_io.h"
#include "fsp/frontend/object_tracker.h"
#include "fsp/frontend/rect_geometry.h"

namespace fsp {
namespace {

// A tracker under test, multi-object like the project's ObjectTracker. Per frame the benchmark
// first calls Track (objects started before), then Start for objects that begin on this frame, so
// Start always gets the frame last given to Track (or the first frame).
struct Candidate {
  virtual ~Candidate() = default;
  virtual std::string Name() const = 0;
  // Starts object `id` at `corners` (undistorted px, s1..s4) in `gray` (CV_8UC1).
  virtual void Start(int id, const cv::Mat& gray, const Corners& corners) = 0;
  // Tracks every started object into `gray`; an object missing from the result is not reported.
  virtual std::map<int, Corners> Track(const cv::Mat& gray) = 0;
};

// The project's tracker (frontend/object_tracker.h): started on the ground truth like the others; a
// returning object counts only when the tracker itself re-finds it (it does not: re-identification
// is the front end's job), and a quad partly out of the image is not reported.
class ProjectCandidate : public Candidate {
 public:
  explicit ProjectCandidate(const PinholeRadtan& camera) : tracker_(camera) {}
  std::string Name() const override { return "FSP ObjectTracker"; }
  void Start(int id, const cv::Mat& gray, const Corners& corners) override {
    tracker_.Start(id, gray, corners);
  }
  std::map<int, Corners> Track(const cv::Mat& gray) override {
    std::map<int, Corners> out;
    for (const frontend::TrackedObject& t : tracker_.Track(gray))
      if (t.tracked && t.in_view) out[t.id] = t.corners_undistorted;
    return out;
  }

 private:
  frontend::ObjectTracker tracker_;
};

cv::Rect2d BoxRect(const Corners& c) {
  const Eigen::AlignedBox2d b = frontend::BoundingBox(c);
  return cv::Rect2d(b.min().x(), b.min().y(), b.sizes().x(), b.sizes().y());
}

// Box -> corners s1..s4 (bottom-left, bottom-right, top-right, top-left; image y points down).
Corners BoxCorners(const cv::Rect2d& b) {
  return {Vec2(b.x, b.y + b.height), Vec2(b.x + b.width, b.y + b.height), Vec2(b.x + b.width, b.y),
          Vec2(b.x, b.y)};
}

// OpenCV's box trackers (one instance per object). They see the grey frame as 3 equal channels,
// since KCF's and CSRT's colour-name features expect colour input.
class OpenCvCandidate : public Candidate {
 public:
  // Both cv::Tracker (KCF, CSRT) and cv::legacy::Tracker (MedianFlow) behind one pair of functions.
  struct Ops {
    std::function<void(const cv::Mat&, const cv::Rect2d&)> init;
    std::function<std::optional<cv::Rect2d>(const cv::Mat&)> update;
  };
  OpenCvCandidate(std::string name, std::function<Ops()> make)
      : name_(std::move(name)), make_(std::move(make)) {}
  std::string Name() const override { return name_; }

  void Start(int id, const cv::Mat& gray, const Corners& corners) override {
    Ops ops = make_();
    ops.init(Colour(gray), BoxRect(corners));
    trackers_[id] = std::move(ops);
  }

  std::map<int, Corners> Track(const cv::Mat& gray) override {
    const cv::Mat bgr = Colour(gray);
    std::map<int, Corners> out;
    for (auto& [id, ops] : trackers_) {
      if (const std::optional<cv::Rect2d> box = ops.update(bgr)) out[id] = BoxCorners(*box);
    }
    return out;
  }

 private:
  static cv::Mat Colour(const cv::Mat& gray) {
    cv::Mat bgr;
    cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
    return bgr;
  }
  std::string name_;
  std::function<Ops()> make_;
  std::map<int, Ops> trackers_;
};

// A tracker of the current (cv::Tracker) API: integer boxes, update() false when it reports a loss.
template <typename T>
OpenCvCandidate::Ops ModernOps() {
  cv::Ptr<cv::Tracker> t = T::create();
  OpenCvCandidate::Ops ops;
  ops.init = [t](const cv::Mat& img, const cv::Rect2d& box) {
    // Round outwards so the box holds the whole quad.
    const int x0 = static_cast<int>(std::floor(box.x)), y0 = static_cast<int>(std::floor(box.y));
    const int x1 = static_cast<int>(std::ceil(box.x + box.width)),
              y1 = static_cast<int>(std::ceil(box.y + box.height));
    t->init(img, cv::Rect(x0, y0, x1 - x0, y1 - y0));
  };
  ops.update = [t](const cv::Mat& img) -> std::optional<cv::Rect2d> {
    cv::Rect r;
    if (!t->update(img, r)) return std::nullopt;
    return cv::Rect2d(r);
  };
  return ops;
}

OpenCvCandidate::Ops MedianFlowOps() {
  cv::Ptr<cv::legacy::Tracker> t = cv::legacy::TrackerMedianFlow::create();
  OpenCvCandidate::Ops ops;
  ops.init = [t](const cv::Mat& img, const cv::Rect2d& box) { t->init(img, box); };
  ops.update = [t](const cv::Mat& img) -> std::optional<cv::Rect2d> {
    cv::Rect2d r;
    if (!t->update(img, r)) return std::nullopt;
    return r;
  };
  return ops;
}

// `camera`: the clip's calibration (the OpenCV trackers do not use it).
std::vector<std::unique_ptr<Candidate>> MakeCandidates(const PinholeRadtan& camera) {
  (void)camera;
  std::vector<std::unique_ptr<Candidate>> c;
  c.push_back(
      std::make_unique<OpenCvCandidate>("OpenCV KCF", [] { return ModernOps<cv::TrackerKCF>(); }));
  c.push_back(std::make_unique<OpenCvCandidate>("OpenCV CSRT",
                                                [] { return ModernOps<cv::TrackerCSRT>(); }));
  c.push_back(std::make_unique<OpenCvCandidate>("OpenCV MedianFlow", MedianFlowOps));
  c.push_back(std::make_unique<ProjectCandidate>(camera));
  return c;
}

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + m, v.end());
  if (v.size() % 2 == 1) return v[m];
  const double hi = v[m];
  return 0.5 * (hi + *std::max_element(v.begin(), v.begin() + m));
}

struct Score {
  int scored = 0;                 // fully visible frames after the start frame
  int ok_2px = 0;                 // of which all 4 corners within 2 px
  int ok_iou = 0;                 // of which box IoU >= 0.5
  int out_of_view = 0;            // reports while the object has no ground-truth row
  std::vector<double> corner_px;  // mean corner distance, frames with a report

  void Add(const Score& o) {
    scored += o.scored;
    ok_2px += o.ok_2px;
    ok_iou += o.ok_iou;
    out_of_view += o.out_of_view;
    corner_px.insert(corner_px.end(), o.corner_px.begin(), o.corner_px.end());
  }
};

struct ClipScore {
  std::map<int, Score> objects;       // by object id
  std::vector<double> ms_per_object;  // per frame: Track() time / started objects
};

// Runs one candidate on a clip. Ground truth: observations_gt.csv of the clip (undistorted px).
ClipScore RunClip(Candidate* cand, const Source& source, const std::vector<CornerRow>& gt_rows) {
  std::map<int64_t, std::map<int, CornerRow>> gt;  // t_ns -> id -> row
  std::set<int> ids;
  for (const CornerRow& r : gt_rows) {
    gt[r.t_ns][r.object_id] = r;
    ids.insert(r.object_id);
  }
  const std::vector<int64_t>& times = source.frame_times();
  std::set<int> started;
  ClipScore cs;
  for (int k = 0; k < static_cast<int>(times.size()); ++k) {
    const Frame frame = source.ReadFrame(k);
    const std::map<int, CornerRow>& now = gt[frame.t_ns];
    if (!started.empty()) {
      const auto t0 = std::chrono::steady_clock::now();
      const std::map<int, Corners> out = cand->Track(frame.image);
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      cs.ms_per_object.push_back(ms / static_cast<double>(started.size()));
      for (int id : started) {
        Score& s = cs.objects[id];
        const auto rep = out.find(id);
        const auto truth = now.find(id);
        if (truth == now.end()) {
          if (rep != out.end()) ++s.out_of_view;
          continue;
        }
        if (!truth->second.FullyVisible()) continue;
        ++s.scored;
        if (rep == out.end()) continue;
        double sum = 0.0, worst = 0.0;
        for (int j = 0; j < 4; ++j) {
          const double d = (rep->second[j] - truth->second.corners[j]).norm();
          sum += d;
          worst = std::max(worst, d);
        }
        s.corner_px.push_back(sum / 4.0);
        if (worst <= 2.0) ++s.ok_2px;
        if (frontend::BoxIou(frontend::BoundingBox(rep->second),
                             frontend::BoundingBox(truth->second.corners)) >= 0.5)
          ++s.ok_iou;
      }
    }
    for (int id : ids) {
      const auto truth = now.find(id);
      if (started.count(id) || truth == now.end() || !truth->second.FullyVisible()) continue;
      cand->Start(id, frame.image, truth->second.corners);
      started.insert(id);
      cs.objects[id];  // scored from the next frame on
    }
  }
  return cs;
}

// "| success 2px | success IoU | median px | out of view |" cells of a score.
std::string Cells(const Score& s) {
  const double pct = s.scored > 0 ? 100.0 / s.scored : 0.0;
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%.1f | %.1f | %.2f | %d", s.ok_2px * pct, s.ok_iou * pct,
                Median(s.corner_px), s.out_of_view);
  return buf;
}

int Main(int argc, char** argv) {
  std::vector<std::string> dirs;
  bool per_object = false;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--per-object") {
      per_object = true;
    } else if (!arg.empty() && arg[0] == '-') {
      dirs.clear();
      break;
    } else {
      dirs.push_back(arg);
    }
  }
  if (dirs.empty()) {
    std::fprintf(
        stderr,
        "usage: %s [--per-object] CLIP_DIR [CLIP_DIR ...]   (folders written by `fsp render`)\n"
        "  --per-object  also print one table row per object\n",
        argv[0]);
    return 2;
  }
  cv::setNumThreads(1);
  std::vector<std::string> object_rows;
  std::printf(
      "| tracker | clip | success 2px %% | success IoU %% | median px | boxes out of view | "
      "ms/frame |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (const std::string& dir : dirs) {
    SourceOptions so;
    so.input = dir;
    const std::unique_ptr<Source> source = OpenSource(so);
    for (double k : source->calibration().camera.distortion) {
      // Ground truth is in undistorted pixels; the trackers see the rendered (distorted) image.
      if (k != 0.0)
        throw InputError(dir, 0, "the clip's camera has lens distortion: corners would not match");
    }
    const std::vector<CornerRow> rows = ReadCornerRows(dir + "/observations_gt.csv");
    const std::string clip = std::filesystem::path(dir).lexically_normal().filename().string();
    // Fresh candidates per clip: no state carries over.
    for (const std::unique_ptr<Candidate>& cand : MakeCandidates(source->calibration().camera)) {
      const ClipScore cs = RunClip(cand.get(), *source, rows);
      Score all;
      for (const auto& [id, s] : cs.objects) {
        all.Add(s);
        object_rows.push_back("| " + cand->Name() + " | " + clip + " | " + std::to_string(id) +
                              " | " + std::to_string(s.scored) + " | " + Cells(s) + " |");
      }
      std::printf("| %s | %s | %s | %.2f |\n", cand->Name().c_str(), clip.c_str(),
                  Cells(all).c_str(), Median(cs.ms_per_object));
      std::fflush(stdout);
    }
  }
  if (per_object) {
    std::printf(
        "\n| tracker | clip | object | scored frames | success 2px %% | success IoU %% | median px "
        "| boxes out of view |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (const std::string& r : object_rows) std::printf("%s\n", r.c_str());
  }
  return 0;
}

}  // namespace
}  // namespace fsp

int main(int argc, char** argv) {
  try {
    return fsp::Main(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_track: %s\n", e.what());
    return 1;
  }
}
