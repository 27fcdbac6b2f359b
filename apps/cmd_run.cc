// fsp run INPUT --out DIR [--calib FILE] [--imu FILE] [--config FILE]
//         [--frontend rect|apriltag|gt-corners|corners] [--corners FILE] [--objects FILE]
//         [--landmarks fsp|fhp] [--mode window|batch] [--realtime] [--follow [--idle-s S]]
//         [--until-s S] [--video FILE] [--show] [--seed N] [--sync]
// Runs the pipeline on a recording and writes trajectory.tum, map.json, observations.csv and
// run.json.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "fsp/common/error.h"
#include "pipeline.h"
#include "run_config.h"

namespace fsp::apps {

namespace {

// Set by SIGINT/SIGTERM during a live run (--follow, --realtime): the pipeline stops reading,
// processes what is queued and writes its outputs. The handler resets itself: a second signal
// ends the program at once.
std::atomic<bool> g_stop{false};

extern "C" void OnStopSignal(int /*signal*/) {
  g_stop.store(true);
}

void InstallStopHandler() {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

struct RunArgs {
  RunRequest request;
  std::string config;
  std::string landmarks;  // empty: from the config
  std::string mode;       // empty: from the config
  std::optional<uint32_t> seed;
  bool print_config = false;
};

void Run(const RunArgs& args) {
  RunConfig config = args.config.empty() ? RunConfig() : ReadRunConfig(args.config);
  if (args.print_config) {
    std::cout << ToYaml(config);
    return;
  }
  if (args.request.source.input.empty()) throw InputError("fsp run: INPUT is required");
  if (args.request.out_dir.empty()) throw InputError("fsp run: --out DIR is required");
  if (args.mode == "window") config.estimator.mode = backend::EstimatorMode::kWindow;
  if (args.mode == "batch") config.estimator.mode = backend::EstimatorMode::kBatch;
  if (args.landmarks == "fsp") config.estimator.landmarks = backend::LandmarkType::kFsp;
  if (args.landmarks == "fhp") config.estimator.landmarks = backend::LandmarkType::kFhp;
  if (args.seed) config.gt_corners.seed = *args.seed;

  RunRequest request = args.request;
  if (!(request.idle_s > 0.0)) throw InputError("fsp run: --idle-s must be > 0");
  request.warn = [](const std::string& w) {
    std::fprintf(stderr, "fsp: warning: %s\n", w.c_str());
  };
  if (request.follow || request.realtime) {
    InstallStopHandler();
    request.stop = &g_stop;
  }
  const RunReport r = RunPipeline(request, config);
  if (!r.summary.init_failure.empty()) {
    throw InputError("initialisation refused: " + r.summary.init_failure);
  }
  std::printf("fsp run: %s, %s landmarks, %s mode, front end %s", r.input.c_str(),
              r.landmarks.c_str(), r.mode.c_str(), r.frontend.c_str());
  if (r.frontend == "gt-corners") std::printf(" (sigma %.3g px, seed %u)", r.pixel_sigma, r.seed);
  if (r.frontend == "corners") std::printf(" (%s)", args.request.corners.c_str());
  std::printf("\n");
  std::printf(
      "  frames %d (%d processed, %d dropped), keyframes %d, observations %d, objects in map %d\n",
      r.frames, r.frames_processed, r.frames_dropped, r.keyframes, r.observations, r.objects);
  if (r.follow) {
    std::printf("  followed until %s; %d images skipped, %d late IMU samples dropped\n",
                r.end == "idle"      ? "idle"
                : r.end == "stopped" ? "stopped (signal)"
                                     : r.end.c_str(),
                r.images_skipped, r.imu_dropped);
  } else if (r.end == "stopped") {
    std::printf("  stopped by a signal after %d frames\n", r.frames);
  }
  // The map as a user reads it: each object's size with its 1-σ (from the final solve's
  // covariance).
  constexpr size_t kListed = 40;
  if (!r.map.empty()) std::printf("  map (width x height, +- 1 sigma):\n");
  for (size_t i = 0; i < r.map.size() && i < kListed; ++i)
    std::printf("    %s\n", MapObjectLine(r.map[i]).c_str());
  if (r.map.size() > kListed) std::printf("    ... %zu more in map.json\n", r.map.size() - kListed);
  if (!r.objects_non_finite_ids.empty()) {
    std::printf(
        "  warning: %zu objects had non-finite estimates and were left out of map.json (ids:",
        r.objects_non_finite_ids.size());
    for (int id : r.objects_non_finite_ids) std::printf(" %d", id);
    std::printf(")\n");
  }
  const backend::EstimatorSummary& f = r.summary;
  if (f.imu_gaps + f.frame_gaps + f.blind_stretches + f.dead_reckoning_stretches + f.divergences >
      0) {
    std::printf(
        "  faults: %d IMU gaps (longest %.2f s), %d frame gaps (longest %.2f s), %d stretches "
        "without objects (longest %.2f s), %d of dead reckoning (longest %.2f s), %d "
        "divergences, %d resets (run.json \"faults\")\n",
        f.imu_gaps, f.imu_gap_max_s, f.frame_gaps, f.frame_gap_max_s, f.blind_stretches,
        f.blind_max_s, f.dead_reckoning_stretches, f.dead_reckoning_max_s, f.divergences, f.resets);
  }
  for (const std::string& w : f.warnings) std::fprintf(stderr, "fsp: warning: %s\n", w.c_str());
  if (!r.frontend_stages.empty()) {
    std::printf("  front end per frame: median %.2f ms, p90 %.2f ms (", r.frontend_ms.median,
                r.frontend_ms.p90);
    for (size_t i = 0; i < r.frontend_stages.size(); ++i)
      std::printf("%s%s %.2f", i ? ", " : "", r.frontend_stages[i].first.c_str(),
                  r.frontend_stages[i].second.median);
    std::printf("); detector ran on %d frames; objects started %d, re-identified %d, lost %d\n",
                r.detector_runs, r.objects_started, r.objects_reidentified, r.objects_lost);
  }
  std::printf("  back end per frame: median %.2f ms, p90 %.2f ms; finish %.1f ms\n",
              r.backend_ms.median, r.backend_ms.p90, r.finish_ms);
  std::printf("  %.2f s of data in %.2f s wall: %.1fx real time\n", r.duration_s, r.wall_s,
              r.realtime_factor);
  std::printf(
      "  wrote trajectory.tum, trajectory_online.tum, map.json, observations.csv%s, run.json to "
      "%s\n",
      args.request.video.empty() ? "" : (", " + args.request.video).c_str(),
      args.request.out_dir.c_str());
  // The followed input ended abnormally: the outputs hold what was processed.
  if (r.end == "folder-gone") {
    std::fprintf(stderr, "fsp: error: %s; the outputs of the %d frames processed are written\n",
                 r.end_message.c_str(), r.frames_processed);
    throw CLI::RuntimeError(3);
  }
  if (r.end == "error") {
    std::fprintf(stderr, "fsp: error: %s; the outputs of the %d frames processed are written\n",
                 r.end_message.c_str(), r.frames_processed);
    throw CLI::RuntimeError(2);
  }
}

}  // namespace

void AddRunCommand(CLI::App& root) {
  auto args = std::make_shared<RunArgs>();
  auto* sub = root.add_subcommand(
      "run",
      "Run FSP-SLAM on a recording: INPUT is a EuRoC-layout folder (a rendered sequence is one), "
      "a\n"
      "DSO / TUM-VI / DM-VIO folder (cam0/{times.txt,camera.txt,images/}, imu.txt, "
      "camchain.yaml),\n"
      "a video or a folder of images named by nanosecond timestamps (both with --imu and "
      "--calib).\n"
      "Writes trajectory.tum, trajectory_online.tum, map.json, observations.csv and run.json to\n"
      "--out DIR (each file written under a temporary name and renamed: never seen half-written).\n"
      "The front end gt-corners reads a rendered sequence's ground-truth corners\n"
      "(observations_gt.csv) plus pixel noise from the config; corners reads another detector's\n"
      "corners (--corners FILE, the same columns, distorted pixels).\n"
      "Live use: --follow processes the images of a folder as a camera driver writes them (the "
      "IMU\n"
      "csv may grow too: complete lines are read as they appear) until no new image arrived for\n"
      "--idle-s or SIGINT/SIGTERM; --realtime replays a recording at its rate and drops the "
      "frames\n"
      "the pipeline cannot keep up with (counted in run.json).\n"
      "The front end and the back end run on their own threads (--sync: one after the other on "
      "one\n"
      "thread, for profiling; the outputs are the same bytes either way).\n"
      "Exit 0 on success (also when stopped by SIGINT/SIGTERM: the outputs are written), 2 on bad\n"
      "input (one line), 3 when a followed folder or IMU csv disappears (the outputs hold the "
      "frames\n"
      "processed).");
  sub->add_option("INPUT", args->request.source.input,
                  "EuRoC-layout folder (DIR/mav0 or mav0 itself), DSO-layout folder, video, or "
                  "image folder");
  sub->add_option("--out", args->request.out_dir, "output folder (created)");
  sub->add_option("--calib", args->request.source.calib,
                  "calibration: EuRoC cam0/sensor.yaml, Kalibr camchain or fsp calib.yaml "
                  "(overrides the folder's)");
  sub->add_option("--imu", args->request.source.imu,
                  "IMU csv t_ns,wx,wy,wz,ax,ay,az (overrides the folder's)");
  sub->add_option("--config", args->config,
                  "YAML configuration (assets/config/default.yaml: the options a user may change; "
                  "--print-config lists every key)");
  sub->add_option("--frontend", args->request.frontend,
                  "front end: rect (rectangles + tag decoding), apriltag, gt-corners (rendered "
                  "sequences) or corners (--corners FILE)")
      ->check(CLI::IsMember({"rect", "apriltag", "gt-corners", "corners"}))
      ->default_str("rect");
  sub->add_option("--corners", args->request.corners,
                  "--frontend corners: csv "
                  "t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4[,fully_visible[,visible_corners]] "
                  "(observations_gt.csv's columns) of corners found in the raw images: distorted "
                  "pixels, s1..s4 order, t_ns the frame times of INPUT");
  sub->add_option("--objects", args->request.objects,
                  "--frontend corners: object classes, {\"objects\": [{\"id\": 1, \"class\": "
                  "\"door\"}, ...]} (objects_gt.json's layout); default: every class unknown");
  sub->add_option("--landmarks", args->landmarks,
                  "rectangle landmarks: fsp (8 DoF) or fhp (12 DoF baseline)")
      ->check(CLI::IsMember({"fsp", "fhp"}));
  sub->add_option("--mode", args->mode,
                  "window (online sliding window) or batch (full problem, the reference)")
      ->check(CLI::IsMember({"window", "batch"}));
  sub->add_flag("--realtime", args->request.realtime,
                "pace the input at its recorded rate and drop frames the pipeline cannot keep up "
                "with, as a live camera would (front end and back end on their own threads; "
                "with --follow: drop instead of falling behind the folder)");
  sub->add_flag("--follow", args->request.follow,
                "INPUT is an image folder a camera driver is filling (<t_ns>.png ..., with --imu "
                "and --calib; the IMU csv may grow too): process images as they appear, until none "
                "arrived for --idle-s or SIGINT/SIGTERM; front end and back end on their own "
                "threads. Exit 3 when the folder disappears (the outputs hold what was processed)");
  sub->add_option("--idle-s", args->request.idle_s,
                  "--follow: stop when no new image arrived for this long [s]")
      ->default_str("5");
  sub->add_option("--until-s", args->request.until_s,
                  "only the first S seconds of the recording: frames and IMU samples up to the "
                  "first frame's time + S (not with --follow)");
  sub->add_flag("--show", args->request.show,
                "show the annotated frame (as --video draws it) in a window while running, where "
                "a display exists (otherwise a warning and no window)");
  sub->add_option("--video", args->request.video,
                  "also write the run as an annotated video (mp4): each frame with the objects "
                  "reported, their ids, classes and sizes, and the top view so far");
  sub->add_flag("--sync", args->request.synchronous,
                "run the front end and the back end one after the other on one thread (same "
                "outputs as the default two threads; for profiling)");
  sub->add_option("--seed", args->seed,
                  "seed of the front end's pixel noise (overrides the config)");
  sub->add_flag("--print-config", args->print_config,
                "print the configuration (defaults, or --config applied) as YAML and exit");
  sub->callback([args] { Run(*args); });
}

}  // namespace fsp::apps
