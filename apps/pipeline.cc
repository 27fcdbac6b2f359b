#include "pipeline.h"

#include "annotated_video.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <thread>

#include "fsp/common/error.h"
#include "fsp/common/observations_io.h"
#include "fsp/common/progress.h"
#include "fsp/common/time.h"
#include "fsp/common/trajectory_io.h"
#include "fsp/pipeline/system.h"
#include "gt_corners.h"

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
  void WaitFor(int64_t t_ns) const { std::this_thread::sleep_until(Due(t_ns)); }

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
  const Clock::time_point wall_start = Clock::now();
  SourceOptions source_options = request.source;
  source_options.decode_images = from_images;  // corners from a file need no pixels
  // The gt-corners front end first: a missing observations_gt.csv is the likelier mistake and its
  // message the clearer. The corners front end needs the frame times.
  std::unique_ptr<CornerFileFrontend> corner_file;
  if (gt)
    corner_file = std::make_unique<GtCornersFrontend>(request.source.input, config.gt_corners);
  std::unique_ptr<Source> source = OpenSource(source_options);
  if (external) {
    corner_file = std::make_unique<ExternalCornersFrontend>(
        request.corners, request.objects, source->calibration(), source->frame_times());
  }

  Calibration calibration = source->calibration();
  calibration.imu = config.imu.Apply(calibration.imu);
  if (!calibration.Check(&why))
    throw InputError((config.source.empty() ? "config" : config.source) + ": " + why);
  system_options.estimator = config.estimator;
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
  report.seed = gt ? config.gt_corners.seed : 0;
  report.pixel_sigma = gt ? config.gt_corners.pixel_sigma : 0.0;
  const std::vector<int64_t>& frame_times = source->frame_times();
  report.frames = static_cast<int>(frame_times.size());
  if (frame_times.size() >= 2)
    report.duration_s = NsToSeconds(frame_times.back() - frame_times.front());

  pipeline::System slam(calibration, system_options);
  std::vector<double> frontend_ms, backend_ms;
  std::map<std::string, std::vector<double>> stage_ms;
  std::vector<std::string> stage_order;
  std::vector<CornerRow> produced;
  const int64_t frame_period_ns = frame_times.size() >= 2
                                      ? (frame_times.back() - frame_times.front()) /
                                            static_cast<int64_t>(frame_times.size() - 1)
                                      : 0;
  std::optional<Pacer> pacer;
  if (request.realtime) {
    const int64_t t_first =
        std::min(frame_times.empty() ? 0 : frame_times.front(),
                 source->imu().empty() ? frame_times.front() : source->imu().front().t_ns);
    pacer.emplace(t_first);
  }
  std::unique_ptr<AnnotatedVideo> video;
  if (!request.video.empty())
    video = std::make_unique<AnnotatedVideo>(request.video, calibration,
                                             frame_period_ns > 0 ? 1e9 / frame_period_ns : 20.0);
  std::unique_ptr<Progress> progress;
  if (request.progress) progress = std::make_unique<Progress>("run", report.frames);
  int frames_seen = 0;
  while (std::optional<Measurement> m = source->Next()) {
    if (const ImuSample* imu = std::get_if<ImuSample>(&*m)) {
      if (pacer) pacer->WaitFor(imu->t_ns);
      slam.AddImu(*imu);
      ++report.imu_samples;
      continue;
    }
    const Frame& frame = std::get<Frame>(*m);
    ++frames_seen;
    if (pacer) {
      // A live camera has the next frame ready by Due(t + period): a frame still unprocessed then
      // is lost.
      if (Clock::now() > pacer->Due(frame.t_ns + frame_period_ns)) {
        ++report.frames_dropped;
        if (progress) progress->Update(frames_seen);
        continue;
      }
      pacer->WaitFor(frame.t_ns);
    }
    pipeline::FrameOutput out;
    if (corner_file) {
      const Clock::time_point t0 = Clock::now();
      std::vector<ObjectObservation> observations = corner_file->Process(frame.t_ns);
      const double ms = MsSince(t0);
      out = slam.AddObservations(frame.t_ns, observations);
      out.frontend_ms = ms;
    } else {
      out = slam.AddFrame(frame);
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
    for (const ObjectObservation& o : out.observations) produced.push_back(ToCornerRow(o));
    if (video) {
      const std::optional<StateSample> latest = slam.Latest();
      video->Add(frame.image, out.observations, slam.Map(),
                 latest && out.estimator_initialized ? std::optional<Rigid3>(latest->T_W_B)
                                                     : std::nullopt);
    }
    report.observations += static_cast<int>(out.observations.size());
    ++report.frames_processed;
    if (progress) progress->Update(frames_seen);
    if (!slam.summary().init_failure.empty()) break;  // nothing more can happen
  }
  const Clock::time_point t_finish = Clock::now();
  slam.Finish();
  report.finish_ms = MsSince(t_finish);
  progress.reset();  // ends the bar's line before anything else is printed
  report.wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();

  if (gt && corner_file->stats().rows > 0 && corner_file->stats().frames_matched == 0 &&
      report.frames_processed > 0) {
    throw InputError(corner_file->observations_path() +
                     ": no row's t_ns matches a frame time of the input (a different sequence?)");
  }

  report.summary = slam.summary();
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
  for (const backend::MapObject& o : slam.Map()) {
    bool finite = std::isfinite(o.width) && std::isfinite(o.height) && o.T_W_O.Matrix().allFinite();
    for (const Vec3& c : o.corners_W) finite = finite && c.allFinite();
    if (finite) {
      map.push_back(o);
    } else {
      report.objects_non_finite_ids.push_back(o.id);
    }
  }
  report.objects = static_cast<int>(map.size());
  WriteTum(slam.Trajectory(), (out / "trajectory.tum").string());
  WriteTum(slam.CausalTrajectory(), (out / "trajectory_online.tum").string());
  WriteJson(MapToJson(map), (out / "map.json").string());
  WriteCornerRows(produced, (out / "observations.csv").string(), /*with_flag=*/false);
  WriteJson(RunReportToJson(report), (out / "run.json").string());
  return report;
}

}  // namespace fsp::apps
