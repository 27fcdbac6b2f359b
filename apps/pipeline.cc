#include "pipeline.h"

#include "annotated_video.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <thread>
#include <variant>

#include <opencv2/core.hpp>

#include "fsp/common/error.h"
#include "fsp/common/folder_follower.h"
#include "fsp/common/observations_io.h"
#include "fsp/common/progress.h"
#include "fsp/common/time.h"
#include "fsp/common/trajectory_io.h"
#include "fsp/pipeline/system.h"
#include "gt_corners.h"
#include "live_window.h"

namespace fsp::apps {

namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Paces measurements at the recorded rate: measurement time t is due at wall time
// start + (t − t_first).
class Pacer {
 public:
  explicit Pacer(int64_t t_first_ns) : t_first_ns_(t_first_ns), start_(Clock::now()) {}
  Clock::time_point Due(int64_t t_ns) const {
    return start_ + std::chrono::nanoseconds(t_ns - t_first_ns_);
  }

 private:
  int64_t t_first_ns_;
  Clock::time_point start_;
};

}  // namespace

const char* ModeName(backend::EstimatorMode mode) {
  return mode == backend::EstimatorMode::kBatch ? "batch" : "window";
}
const char* LandmarkName(backend::LandmarkType landmarks) {
  return landmarks == backend::LandmarkType::kFhp ? "fhp" : "fsp";
}

namespace {

// Sleeps until DUE, waking every 50 ms to look at STOP; false when STOP was set.
bool SleepUntil(Clock::time_point due, const std::atomic<bool>* stop) {
  for (;;) {
    if (stop && stop->load()) return false;
    const Clock::time_point now = Clock::now();
    if (now >= due) return true;
    std::this_thread::sleep_until(std::min(due, now + std::chrono::milliseconds(50)));
  }
}

}  // namespace

RunReport RunPipeline(const RunRequest& request, const RunConfig& config) {
  const bool gt = request.frontend == "gt-corners";
  const bool external = request.frontend == "corners";
  const bool from_images = !gt && !external;
  pipeline::SystemOptions system_options;
  system_options.frontend = config.frontend;
  if (from_images &&
      !frontend::ParseDetectorKind(request.frontend, &system_options.frontend.detector)) {
    throw InputError("--frontend " + request.frontend +
                     ": unknown (rect, apriltag, gt-corners or corners)");
  }
  if (external && request.corners.empty())
    throw InputError("--frontend corners needs --corners FILE");
  if (!external && (!request.corners.empty() || !request.objects.empty()))
    throw InputError("--corners and --objects go with --frontend corners");
  std::string why;
  if (!config.estimator.Check(&why))
    throw InputError((config.source.empty() ? "config" : config.source) + ": " + why);

  namespace fs = std::filesystem;
  if (!fs::exists(request.source.input))
    throw InputError(request.source.input + ": INPUT not found");
  if (request.synchronous && (request.follow || request.realtime))
    throw InputError("--sync does not go with --follow or --realtime (live runs use two threads)");
  if (request.until_s < 0.0 || !std::isfinite(request.until_s))
    throw InputError("--until-s must be > 0");
  if (request.follow && request.until_s > 0.0)
    throw InputError("--until-s does not go with --follow");
  if (request.follow) {
    if (!from_images)
      throw InputError("--follow reads images: use --frontend rect or apriltag (not " +
                       request.frontend + ")");
    if (!fs::is_directory(request.source.input) ||
        fs::is_directory(fs::path(request.source.input) / "cam0") ||
        fs::is_directory(fs::path(request.source.input) / "mav0"))
      throw InputError(request.source.input +
                       ": --follow follows a folder of images named by their nanosecond "
                       "timestamps (not a video, a EuRoC or a DSO layout)");
    if (!request.source.frame_times.empty())
      throw InputError("--frame-times does not go with --follow");
  }
  const Clock::time_point wall_start = Clock::now();
  // The input: a recording read whole (Source) or a followed folder (FolderFollower).
  std::unique_ptr<Source> source;
  std::unique_ptr<FolderFollower> follower;
  std::unique_ptr<CornerFileFrontend> corner_file;
  // camera.time_offset_s replaces the calibration's offset in either.
  std::optional<int64_t> time_offset_ns;
  if (config.camera_time_offset_s)
    time_offset_ns = std::llround(*config.camera_time_offset_s * 1e9);
  if (request.follow) {
    FollowOptions follow;
    follow.folder = request.source.input;
    follow.calib = request.source.calib;
    follow.imu = request.source.imu;
    follow.time_offset_ns = time_offset_ns;
    follow.idle_s = request.idle_s;
    follow.poll_s = request.poll_s;
    follow.stop = request.stop;
    follow.warn = request.warn;
    follower = std::make_unique<FolderFollower>(follow);
  } else {
    SourceOptions source_options = request.source;
    source_options.decode_images = from_images;  // corners from a file need no pixels
    source_options.time_offset_ns = time_offset_ns;
    // The gt-corners front end first: a missing observations_gt.csv is the likelier mistake and
    // its message the clearer. The corners front end needs the frame times.
    if (gt)
      corner_file = std::make_unique<GtCornersFrontend>(request.source.input, config.gt_corners);
    source = OpenSource(source_options);
    if (external) {
      corner_file = std::make_unique<ExternalCornersFrontend>(
          request.corners, request.objects, source->calibration(), source->frame_times(),
          config.gt_corners.min_visible_corners);
    }
  }

  Calibration calibration = source ? source->calibration() : follower->calibration();
  calibration.imu = config.imu.Apply(calibration.imu);
  if (!calibration.Check(&why))
    throw InputError((config.source.empty() ? "config" : config.source) + ": " + why);
  system_options.estimator = config.estimator;
  if (system_options.estimator.keyframe_min_frames == 0)  // auto (see EstimatorOptions)
    system_options.estimator.keyframe_min_frames = from_images ? 2 : 1;
  system_options.estimator.imu.noise = calibration.imu;
  const backend::EstimatorOptions& options = system_options.estimator;

  std::error_code ec;
  fs::create_directories(request.out_dir, ec);
  if (ec || !fs::is_directory(request.out_dir))
    throw InputError(request.out_dir + ": cannot create the output folder");

  RunReport report;
  report.input = request.source.input;
  report.frontend = request.frontend;
  report.mode = ModeName(options.mode);
  report.landmarks = LandmarkName(options.landmarks);
  report.config = config.source;
  report.realtime = request.realtime;
  report.follow = request.follow;
  report.threaded = !request.synchronous;  // --sync is refused with the live modes (above)
  report.seed = gt ? config.gt_corners.seed : 0;
  report.pixel_sigma = gt ? config.gt_corners.pixel_sigma : 0.0;
  int64_t frame_period_ns = 0;
  // --until-s: measurements after this time are not read.
  int64_t until_ns = std::numeric_limits<int64_t>::max();
  if (source) {
    std::vector<int64_t> frame_times = source->frame_times();
    if (request.until_s > 0.0) {
      until_ns = frame_times.front() + std::llround(request.until_s * 1e9);
      frame_times.erase(std::upper_bound(frame_times.begin(), frame_times.end(), until_ns),
                        frame_times.end());
    }
    report.frames = static_cast<int>(frame_times.size());
    if (frame_times.size() >= 2) {
      report.duration_s = NsToSeconds(frame_times.back() - frame_times.front());
      frame_period_ns =
          (frame_times.back() - frame_times.front()) / static_cast<int64_t>(frame_times.size() - 1);
    }
  } else {
    frame_period_ns = static_cast<int64_t>(std::llround(1e9 / calibration.camera_rate_hz));
  }

  LiveWindow window;  // before any thread starts (see WindowOpensInChild)
  if (request.show && !window.Open(&why) && request.warn) request.warn(why);
  // Threaded (the default) or synchronous (--sync); one of the two, with the same prediction lag
  // so that both give the same bytes.
  std::unique_ptr<pipeline::System> sync;
  std::unique_ptr<pipeline::ThreadedSystem> threaded;
  const bool keep_images = !request.video.empty() || request.show;
  system_options.prediction_lag = 1;
  if (report.threaded) {
    pipeline::ThreadOptions thread_options;
    thread_options.keep_images = keep_images;
    threaded =
        std::make_unique<pipeline::ThreadedSystem>(calibration, system_options, thread_options);
  } else {
    sync = std::make_unique<pipeline::System>(calibration, system_options);
  }
  std::vector<double> frontend_ms, backend_ms;
  std::map<std::string, std::vector<double>> stage_ms;
  std::vector<std::string> stage_order;
  std::vector<CornerRow> produced;
  std::optional<Pacer> pacer;
  if (request.realtime && source) {
    const std::vector<int64_t>& frame_times = source->frame_times();
    const int64_t t_first =
        std::min(frame_times.empty() ? 0 : frame_times.front(),
                 source->imu().empty() ? frame_times.front() : source->imu().front().t_ns);
    pacer.emplace(t_first);
  }
  std::unique_ptr<AnnotatedVideo> video;
  if (keep_images)
    video = std::make_unique<AnnotatedVideo>(request.video, calibration,
                                             frame_period_ns > 0 ? 1e9 / frame_period_ns : 20.0);
  std::unique_ptr<Progress> progress;
  if (request.progress) progress = std::make_unique<Progress>("run", report.frames);
  int frames_seen = 0;

  // One processed frame's output: statistics, the observations, the video and the window.
  const auto consume = [&](const cv::Mat& image, const pipeline::FrameOutput& out,
                           const std::optional<StateSample>& latest,
                           const std::vector<backend::MapObject>& map) {
    if (!corner_file) {
      for (const auto& [stage, ms] : out.frontend_times.ms) {
        if (!stage_ms.count(stage)) stage_order.push_back(stage);
        // The detector's time over the frames it ran on; the others over every frame.
        if (stage != "detect" || out.detector_ran) stage_ms[stage].push_back(ms);
      }
      report.detector_runs += out.detector_ran;
      report.objects_started += out.objects_started;
      report.objects_reidentified += out.objects_reidentified;
      report.objects_lost += out.objects_lost;
    }
    frontend_ms.push_back(out.frontend_ms);
    backend_ms.push_back(out.backend_ms);
    // observations.csv and the video hold boxes: objects wholly in view (gt-corners hands the back
    // end the corners an object partly in view shows as well; run.json counts them).
    std::vector<ObjectObservation> boxes;
    for (const ObjectObservation& o : out.observations) {
      if (!o.Complete()) continue;
      produced.push_back(ToCornerRow(o));
      boxes.push_back(o);
    }
    if (video) {
      video->Add(image, boxes, map,
                 latest && out.estimator_initialized ? std::optional<Rigid3>(latest->T_W_B)
                                                     : std::nullopt);
      window.Show(video->last());
    }
    report.observations += static_cast<int>(out.observations.size());
    ++report.frames_processed;
  };
  const auto drain = [&] {
    for (const pipeline::FrameResult& r : threaded->TakeResults()) {
      static const std::vector<backend::MapObject> kNoMap;
      consume(r.frame.image, r.output, r.state ? r.state->latest : std::nullopt,
              r.state ? r.state->map : kNoMap);
    }
  };
  const auto next = [&]() -> std::optional<Measurement> {
    if (follower) return follower->Next();
    if (request.stop && request.stop->load()) return std::nullopt;
    std::optional<Measurement> m = source->Next();
    if (m && std::visit([](const auto& x) { return x.t_ns; }, *m) > until_ns) return std::nullopt;
    return m;
  };

  while (std::optional<Measurement> m = next()) {
    if (const ImuSample* imu = std::get_if<ImuSample>(&*m)) {
      if (pacer && !SleepUntil(pacer->Due(imu->t_ns), request.stop)) continue;
      if (sync) {
        sync->AddImu(*imu);
      } else {
        threaded->AddImu(*imu);
      }
      ++report.imu_samples;
      if (threaded) drain();  // the window and the statistics keep up while no frame comes
      continue;
    }
    Frame& frame = std::get<Frame>(*m);
    if (pacer && !SleepUntil(pacer->Due(frame.t_ns), request.stop)) continue;
    ++frames_seen;
    if (frames_seen == 1 && from_images && request.warn && !frame.image.empty()) {
      // A sequence rendered with --no-images lists one grey placeholder for every frame: nothing to
      // detect, and no error would say why the map stays empty.
      double lo = 0.0, hi = 0.0;
      cv::minMaxLoc(frame.image, &lo, &hi);
      if (lo == hi)
        request.warn(request.source.input +
                     ": the first image is one uniform grey level (a sequence rendered with "
                     "--no-images has no pixels: use --frontend gt-corners)");
    }
    std::vector<ObjectObservation> observations;
    double file_ms = 0.0;
    if (corner_file) {
      const Clock::time_point t0 = Clock::now();
      observations = corner_file->Process(frame.t_ns);
      file_ms = MsSince(t0);
    }
    if (sync) {
      pipeline::FrameOutput out;
      if (corner_file) {
        out = sync->AddObservations(frame.t_ns, observations);
        out.frontend_ms = file_ms;
      } else {
        out = sync->AddFrame(frame);
      }
      const std::optional<StateSample> latest = sync->Latest();
      consume(frame.image, out, latest, video ? sync->Map() : std::vector<backend::MapObject>());
      if (!sync->summary().init_failure.empty()) break;  // nothing more can happen
    } else {
      // A live camera drops what the pipeline cannot keep up with; a followed folder keeps every
      // frame unless --realtime asks for the same.
      const bool drop = request.realtime;
      report.frames_dropped +=
          corner_file ? threaded->AddObservations(frame.t_ns, std::move(observations), drop)
                      : threaded->AddFrame(std::move(frame), drop);
      drain();
      if (threaded->stopped()) break;
    }
    if (progress) progress->Update(frames_seen);
  }
  const Clock::time_point t_finish = Clock::now();
  if (sync) {
    sync->Finish();
  } else {
    threaded->Finish();
    drain();
  }
  report.finish_ms = MsSince(t_finish);
  progress.reset();  // ends the bar's line before anything else is printed
  report.wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();
  if (follower) {
    report.frames = frames_seen;
    report.images_skipped = follower->images_skipped();
    report.imu_dropped = follower->imu_dropped();
    report.duration_s = NsToSeconds(follower->t_last_ns() - follower->t_first_ns());
    report.end = ToString(follower->end());
    report.end_message = follower->message();
    if (frames_seen == 0 && follower->end() != FollowEnd::kFolderGone &&
        follower->end() != FollowEnd::kError) {
      throw InputError(request.source.input + ": no image arrived (" + report.end +
                       "): nothing to process");
    }
  } else if (request.stop && request.stop->load()) {
    // Stopped: the frames read are the frames.
    report.end = "stopped";
    report.frames = frames_seen;
  }

  if (gt && corner_file->stats().rows > 0 && corner_file->stats().frames_matched == 0 &&
      report.frames_processed > 0) {
    throw InputError(corner_file->observations_path() +
                     ": no row's t_ns matches a frame time of the input (a different sequence?)");
  }

  report.summary = sync ? sync->summary() : threaded->summary();
  if (!report.summary.init_failure.empty()) report.end = "refused";
  report.keyframes = report.summary.keyframes;
  report.frontend_ms = ComputeStageStats(frontend_ms);
  report.backend_ms = ComputeStageStats(backend_ms);
  for (const std::string& stage : stage_order)
    report.frontend_stages.emplace_back(stage, ComputeStageStats(stage_ms[stage]));
  report.realtime_factor = report.wall_s > 0.0 ? report.duration_s / report.wall_s : 0.0;

  const fs::path out(request.out_dir);
  // map.json holds finite numbers only: an object whose estimate is not finite (a back-end failure)
  // is left out and counted.
  std::vector<backend::MapObject> map;
  for (const backend::MapObject& o : sync ? sync->Map() : threaded->Map()) {
    bool finite = std::isfinite(o.width) && std::isfinite(o.height) && o.T_W_O.Matrix().allFinite();
    for (const Vec3& c : o.corners_W) finite = finite && c.allFinite();
    if (finite) {
      map.push_back(o);
    } else {
      report.objects_non_finite_ids.push_back(o.id);
    }
  }
  report.objects = static_cast<int>(map.size());
  report.map = map;
  WriteTum(sync ? sync->Trajectory() : threaded->Trajectory(), (out / "trajectory.tum").string());
  WriteTum(sync ? sync->CausalTrajectory() : threaded->CausalTrajectory(),
           (out / "trajectory_online.tum").string());
  WriteJson(MapToJson(map), (out / "map.json").string());
  WriteCornerRows(produced, (out / "observations.csv").string(), /*with_flag=*/false);
  if (video && !request.video.empty()) {
    video->AddSummary(map);
    video->Close();
  }
  WriteJson(RunReportToJson(report), (out / "run.json").string());
  return report;
}

}  // namespace fsp::apps
