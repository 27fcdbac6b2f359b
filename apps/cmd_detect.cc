// fsp detect IMAGE... [--frontend rect|apriltag] [--calib FILE] [--labels FILE] [--out DIR]:
// corners of the rectangles or AprilTags in single images, a detections.csv and a drawn PNG per
// image (the README's "Commands"); with --labels, only the labelled images, scored against the
// labels.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "commands.h"
#include "fsp/common/calibration.h"
#include "fsp/common/error.h"
#include "fsp/common/median.h"
#include "fsp/frontend/apriltag_detector.h"
#include "fsp/frontend/detection_eval.h"
#include "fsp/frontend/draw.h"
#include "fsp/frontend/image_io.h"
#include "fsp/frontend/rect_detector.h"
#include "run_config.h"

namespace fsp::apps {

namespace {

struct DetectArgs {
  std::vector<std::string> images;
  std::string frontend = "rect";
  std::string calib;
  std::string labels;
  std::string config;
  // -1: the config's (or the default) frontend.rect.detect_long_side.
  int detect_long_side = -1;
  std::string out;
  // AprilTag options (family, sigma, decoding) as given; decimate and refine_edges are set per
  // image from the two below.
  frontend::AprilTagDetectorOptions tag;
  // Decimation for still images; 0 = chosen from the image size (1 below 2000 px on the longer
  // side: a still photo has the time to spare, and decimation loses small tags and moves corners by
  // ~0.5 px; then the factor that brings the longer side under 2000 px).
  double decimate = 0.0;
  // auto: only when decimating (the edges of a decimated quad are snapped to the full image; at
  // decimate 1 the snapping moves the corners of the reference photos by ~0.5 px).
  std::string refine_edges = "auto";
  frontend::RectDetectorOptions rect;
};

// AprilTag quad decimation for a still image whose longer side is `long_side` px.
double StillImageDecimation(int long_side) {
  return std::max(1.0, std::ceil(long_side / 2000.0 - 1e-9));
}

// The label score as a table on stdout: per labelled class, then in total.
void PrintLabelScore(const frontend::LabelScore& s) {
  std::printf("\n%-10s %5s %5s %7s %5s %9s %18s\n", "class", "full", "found", "recall", "cut",
              "cut found", "corner median [px]");
  const auto row = [](const std::string& name, const frontend::LabelScore::PerClass& c) {
    const double median = c.corner_err_px.empty() ? NAN : Median(c.corner_err_px);
    std::printf("%-10s %5d %5d %6.1f%% %5d %9d %18.2f\n", name.c_str(), c.full, c.found,
                c.full ? 100.0 * c.found / c.full : 100.0, c.cut, c.cut_found, median);
  };
  for (const auto& [name, c] : s.per_class) row(name, c);
  row("total", s.Total());
  std::printf(
      "%d frames: %d detections (on ignored labels left out), %d on a labelled object: "
      "precision %.1f %%, recall %.1f %%\n",
      s.frames, s.detections, s.true_positives, 100.0 * s.Precision(), 100.0 * s.Recall());
}

void RunDetect(const DetectArgs& args) {
  std::optional<Calibration> calib;
  if (std::filesystem::path(args.calib).extension() == ".txt") {
    calib.emplace();  // a DSO / DM-VIO camera.txt: the camera alone is all detection needs
    calib->camera = ReadDsoCamera(args.calib);
  } else if (!args.calib.empty()) {
    calib = ReadCalibration(args.calib);
  }
  std::optional<frontend::FrameLabels> labels;
  std::map<int64_t, const frontend::LabelledFrame*> labelled;
  if (!args.labels.empty()) {
    labels = frontend::ReadFrameLabels(args.labels);
    for (const auto& f : labels->frames) labelled[f.t_ns] = &f;
  }
  frontend::LabelScore score;
  std::unique_ptr<frontend::RectDetector> rect;
  std::unique_ptr<frontend::AprilTagDetector> tags;
  frontend::AprilTagDetectorOptions tag_o = args.tag;
  double tag_decimate = -1.0;  // of the detector in `tags`
  if (args.frontend != "apriltag") {
    frontend::RectDetectorOptions rect_o =
        args.config.empty() ? args.rect : ReadRunConfig(args.config).frontend.rect;
    if (args.detect_long_side >= 0) rect_o.detect_long_side = args.detect_long_side;
    std::string why;
    if (!rect_o.Check(&why)) throw InputError("--detect-long-side", 0, why);
    rect = std::make_unique<frontend::RectDetector>(rect_o);
  }
  std::ofstream csv;
  if (!args.out.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(args.out, ec);
    if (ec) throw InputError(args.out, 0, "cannot create output directory (" + ec.message() + ")");
    csv.open(args.out + "/detections.csv");
    if (!csv) throw InputError(args.out + "/detections.csv", 0, "cannot write");
    csv << "image,tag_id,class,u1,v1,u2,v2,u3,v3,u4,v4,score\n";
  }
  for (const std::string& path : args.images) {
    // With labels: the images named <t_ns>.<ext> of a labelled frame only.
    const frontend::LabelledFrame* frame = nullptr;
    if (labels) {
      const std::string stem = std::filesystem::path(path).stem().string();
      char* end = nullptr;
      const long long t_ns = std::strtoll(stem.c_str(), &end, 10);
      const auto it = end && *end == '\0' && !stem.empty() ? labelled.find(t_ns) : labelled.end();
      if (it == labelled.end()) continue;
      frame = it->second;
      labelled.erase(it);
    }
    const cv::Mat gray = frontend::ReadGray8(path);
    const PinholeRadtan* cam = nullptr;
    if (calib) {
      if (calib->camera.width != gray.cols || calib->camera.height != gray.rows)
        throw InputError(path, 0,
                         "image is " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                             " but the calibration " + args.calib + " is for " +
                             std::to_string(calib->camera.width) + "x" +
                             std::to_string(calib->camera.height));
      cam = &calib->camera;
    }
    std::vector<frontend::Detection> dets;
    frontend::StageTimes times;
    std::string counts;  // rectangles: what each stage passed on
    if (args.frontend == "apriltag") {
      const double decimate = args.decimate > 0.0
                                  ? args.decimate
                                  : StillImageDecimation(std::max(gray.cols, gray.rows));
      if (!tags || decimate != tag_decimate) {
        tag_o.decimate = decimate;
        tag_o.refine_edges =
            args.refine_edges == "auto" ? decimate > 1.0 : args.refine_edges == "true";
        std::string why;
        if (!tag_o.Check(&why)) throw InputError("--frontend apriltag", 0, why);
        tags = std::make_unique<frontend::AprilTagDetector>(tag_o);
        tag_decimate = decimate;
      }
      auto r = tags->Detect(gray, cam);
      dets = std::move(r.detections);
      times = r.times;
    } else {
      auto r = rect->Detect(gray, cam);
      dets = std::move(r.detections);
      times = r.times;
      counts = "; " + std::to_string(r.segments) + " segments, " + std::to_string(r.hypotheses) +
               " hypotheses, " + std::to_string(r.refined) + " refined";
    }
    if (frame) {
      if (gray.cols != labels->width || gray.rows != labels->height)
        throw InputError(path, 0, "image size differs from the labels' image_size");
      score.Merge(frontend::ScoreLabelledFrame(dets, *frame, gray.cols, gray.rows));
    }
    const std::string name = std::filesystem::path(path).filename().string();
    std::printf("%s: %zu %s in %.1f ms (%s%s)\n", path.c_str(), dets.size(),
                tags ? "tags" : "rectangles", times.Total(), times.ToString().c_str(),
                counts.c_str());
    if (!args.out.empty()) {
      char buf[512];
      for (const auto& d : dets) {
        std::snprintf(buf, sizeof(buf), "%s,%d,%s,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.4f\n",
                      name.c_str(), d.tag_id, ToString(d.object_class), d.corners_px[0].x(),
                      d.corners_px[0].y(), d.corners_px[1].x(), d.corners_px[1].y(),
                      d.corners_px[2].x(), d.corners_px[2].y(), d.corners_px[3].x(),
                      d.corners_px[3].y(), d.score);
        csv << buf;
      }
      const std::string png =
          args.out + "/" + std::filesystem::path(path).stem().string() + "_detect.png";
      if (!cv::imwrite(png, frontend::DrawDetections(gray, dets)))
        throw InputError(png, 0, "cannot write the drawn image");
    }
  }
  if (csv.is_open() && !csv.flush())
    throw InputError(args.out + "/detections.csv", 0, "write failed");
  if (labels) {
    if (!labelled.empty())
      std::fprintf(stderr, "fsp: warning: %zu of %zu labelled frames are not among the images\n",
                   labelled.size(), labels->frames.size());
    if (score.frames == 0) throw InputError(args.labels, 0, "no image of a labelled frame given");
    PrintLabelScore(score);
  }
}

}  // namespace

void AddDetectCommand(CLI::App& root) {
  auto args = std::make_shared<DetectArgs>();
  auto* sub = root.add_subcommand("detect",
                                  "Detect rectangles (or AprilTags) in images: corners in s1..s4 "
                                  "order (bottom-left, bottom-right,\n"
                                  "top-right, top-left), DIR/detections.csv in distorted image "
                                  "pixels and a drawn PNG per image");
  sub->add_option("images", args->images, "8-bit images (PNG, JPEG, ...)")->required();
  sub->add_option("--frontend", args->frontend, "rect (plain rectangles) or apriltag")
      ->check(CLI::IsMember({"rect", "apriltag"}));
  sub->add_option("--family", args->tag.family, "AprilTag family (with --frontend apriltag)");
  sub->add_option("--decimate", args->decimate,
                  "AprilTag quad decimation; 0 (default) = from the image size: 1 up to 2000 px on "
                  "the longer side");
  sub->add_option("--sigma", args->tag.sigma, "AprilTag Gaussian blur before quad detection [px]")
      ->capture_default_str();
  sub->add_option("--refine-edges", args->refine_edges,
                  "AprilTag: snap quad edges to the full-resolution gradients: auto (when "
                  "decimating), true, false")
      ->check(CLI::IsMember({"auto", "true", "false"}))
      ->capture_default_str();
  sub->add_option("--decode-sharpening", args->tag.decode_sharpening,
                  "AprilTag decoding sharpening")
      ->capture_default_str();
  sub->add_option("--max-hamming", args->tag.max_hamming, "AprilTag: bit errors corrected")
      ->capture_default_str();
  sub->add_option("--min-decision-margin", args->tag.min_decision_margin,
                  "AprilTag: smallest decision margin kept")
      ->capture_default_str();
  sub->add_option("--detect-long-side", args->detect_long_side,
                  "rectangles: images with a longer side >= 2x this are detected on a level "
                  "reduced by an integer factor to >= this [px], corners refined at full "
                  "resolution; 0 = full resolution (default: frontend.rect.detect_long_side, " +
                      std::to_string(args->rect.detect_long_side) + ")");
  sub->add_option("--config", args->config,
                  "the rectangle detector's options from an fsp run config (frontend.rect.*)")
      ->check(CLI::ExistingFile);
  sub->add_option(
      "--calib", args->calib,
      "camera calibration (EuRoC sensor.yaml, Kalibr camchain, fsp calib.yaml, or a DSO/DM-VIO\n"
      "camera.txt): sides are fitted as straight lines after undistortion");
  sub->add_option("--labels", args->labels,
                  "hand labels of the frames (JSON, tests/frontend/data/README.md): detect only "
                  "the images named <t_ns>.<ext> that are labelled and score them (recall, "
                  "precision, corner error per class)")
      ->check(CLI::ExistingFile);
  sub->add_option("--out", args->out, "output folder for detections.csv and the drawn PNGs");
  sub->callback([args] { RunDetect(*args); });
}

}  // namespace fsp::apps
