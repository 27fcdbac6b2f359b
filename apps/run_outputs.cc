#include "run_outputs.h"

#include <algorithm>
#include <cstdio>

#include "fsp/common/atomic_file.h"
#include "fsp/common/error.h"
#include "fsp/common/median.h"

namespace fsp::apps {

namespace {

nlohmann::ordered_json StatsJson(const StageStats& s) {
  return {
      {"median", s.median}, {"p90", s.p90}, {"mean", s.mean}, {"max", s.max}, {"count", s.count}};
}

}  // namespace

StageStats ComputeStageStats(std::vector<double> ms) {
  StageStats s;
  s.count = static_cast<int>(ms.size());
  if (ms.empty()) return s;
  s.median = Percentile(ms, 0.5);
  s.p90 = Percentile(ms, 0.9);
  double sum = 0.0;
  for (double v : ms) sum += v;
  s.mean = sum / static_cast<double>(ms.size());
  s.max = *std::max_element(ms.begin(), ms.end());
  return s;
}

namespace {
// The back end's median time per frame in each tenth of the run (frames in order) [ms]: whether
// the cost per frame grows with the run.
std::vector<double> BackendByTenth(const std::vector<double>& ms) {
  std::vector<double> out;
  if (ms.size() < 10) return out;
  for (size_t k = 0; k < 10; ++k) {
    const auto begin = ms.begin() + static_cast<std::ptrdiff_t>(k * ms.size() / 10);
    const auto end = ms.begin() + static_cast<std::ptrdiff_t>((k + 1) * ms.size() / 10);
    out.push_back(ComputeStageStats(std::vector<double>(begin, end)).median);
  }
  return out;
}
}  // namespace

std::string MapObjectLine(const backend::MapObject& o) {
  char line[160];
  if (o.width_sigma > 0.0 && o.height_sigma > 0.0) {
    std::snprintf(line, sizeof(line), "%d %s  %.3f +- %.3f x %.3f +- %.3f m", o.id,
                  ToString(o.object_class), o.width, o.width_sigma, o.height, o.height_sigma);
  } else {
    std::snprintf(line, sizeof(line), "%d %s  %.3f x %.3f m", o.id, ToString(o.object_class),
                  o.width, o.height);
  }
  return line;
}

nlohmann::ordered_json MapToJson(const std::vector<backend::MapObject>& objects) {
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const backend::MapObject& o : objects) {
    nlohmann::ordered_json j;
    j["id"] = o.id;
    j["class"] = ToString(o.object_class);
    nlohmann::ordered_json corners = nlohmann::ordered_json::array();
    for (const Vec3& c : o.corners_W) corners.push_back({c.x(), c.y(), c.z()});
    j["corners_W"] = corners;
    j["width"] = o.width;
    j["height"] = o.height;
    j["width_sigma"] =
        o.width_sigma >= 0.0 ? nlohmann::ordered_json(o.width_sigma) : nlohmann::ordered_json();
    j["height_sigma"] =
        o.height_sigma >= 0.0 ? nlohmann::ordered_json(o.height_sigma) : nlohmann::ordered_json();
    const Mat4 M = o.T_W_O.Matrix();
    nlohmann::ordered_json t = nlohmann::ordered_json::array();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) t.push_back(M(r, c));
    j["T_W_O"] = t;
    j["observations"] = o.observations;
    list.push_back(j);
  }
  nlohmann::ordered_json root;
  root["objects"] = list;
  return root;
}

nlohmann::ordered_json RunReportToJson(const RunReport& r) {
  nlohmann::ordered_json j;
  j["frames"] = r.frames;
  j["keyframes"] = r.keyframes;
  j["objects"] = r.objects;
  j["wall_s"] = r.wall_s;
  j["realtime_factor"] = r.realtime_factor;
  j["stage_ms"] = {{"frontend", StatsJson(r.frontend_ms)},
                   {"backend", StatsJson(r.backend_ms)},
                   {"finish", r.finish_ms}};
  for (const auto& [stage, stats] : r.frontend_stages) j["stage_ms"][stage] = StatsJson(stats);
  j["duration_s"] = r.duration_s;
  j["frames_processed"] = r.frames_processed;
  j["frames_dropped"] = r.frames_dropped;
  j["images_skipped"] = r.images_skipped;
  j["imu_dropped"] = r.imu_dropped;
  j["imu_samples"] = r.imu_samples;
  j["observations"] = r.observations;
  j["objects_non_finite"] = r.objects_non_finite_ids;
  j["input"] = r.input;
  j["frontend"] = r.frontend;
  j["mode"] = r.mode;
  j["landmarks"] = r.landmarks;
  j["realtime"] = r.realtime;
  j["follow"] = r.follow;
  j["threaded"] = r.threaded;
  j["end"] = r.end;
  j["end_message"] = r.end_message;
  j["seed"] = r.seed;
  j["pixel_sigma"] = r.pixel_sigma;
  j["config"] = r.config.empty() ? "defaults" : r.config;
  if (!r.frontend_stages.empty())
    j["tracking"] = {{"detector_runs", r.detector_runs},
                     {"objects_started", r.objects_started},
                     {"objects_reidentified", r.objects_reidentified},
                     {"objects_lost", r.objects_lost}};
  const backend::EstimatorSummary& s = r.summary;
  j["estimator"] = {
      {"initialized", s.initialized},
      {"init_failure", s.init_failure},
      {"init_in_motion", s.init_in_motion},
      {"init_t_s", s.init_t_s},
      {"init_method", s.init_method},
      {"init_gyro_bias", {s.init_gyro_bias.x(), s.init_gyro_bias.y(), s.init_gyro_bias.z()}},
      {"init_acc_bias", {s.init_acc_bias.x(), s.init_acc_bias.y(), s.init_acc_bias.z()}},
      {"init_speed", s.init_speed},
      {"init_gravity_error", s.init_gravity_error},
      {"init_scale", s.init_scale},
      {"init_baseline_m", s.init_baseline_m},
      {"init_baseline_end_t_s", s.init_baseline_end_t_s},
      {"init_attempts_refused", s.init_attempts_refused},
      {"init_last_refusal", s.init_last_refusal},
      {"init_refusals", s.init_refusals},
      {"observations_used", s.observations_used},
      {"observations_partial", s.observations_partial},
      {"partial_dropped", s.partial_dropped},
      {"starts_rejected", s.starts_rejected},
      {"objects_moving", s.objects_moving},
      {"objects_rejected", s.objects_rejected},
      {"observations_rejected", s.observations_rejected},
      {"reanchors", s.reanchors},
      {"marginalizations", s.marginalizations},
      {"marginalization_failures", s.marginalization_failures},
      {"zero_velocity_keyframes", s.zero_velocity_keyframes},
      {"motion_only_frames", s.motion_only_frames},
      {"zero_velocity_stretches", s.zero_velocity_stretches},
      {"batch_solve_ms", s.batch_solve_ms},
      {"backend_ms_by_tenth", BackendByTenth(s.backend_ms)},
      {"scale_sigma", s.scale_sigma},
      {"variance_factor", s.variance_factor},
      {"imu_chi2_per_residual", s.imu_chi2_per_residual},
      {"corner_chi2_per_residual", s.corner_chi2_per_residual},
      {"final_cost", s.final_cost}};
  if (s.point_frames > 0) {  // points given (PointOptions); absent otherwise, as before them
    j["estimator"]["points"] = {
        {"frames", s.point_frames},
        {"used", s.points_used},
        {"rejected", s.points_rejected},
        {"dropped", s.points_dropped},
        {"reanchored", s.points_reanchored},
        {"mean_track_keyframes",
         s.points_used > 0 ? static_cast<double>(s.point_track_keyframes) / s.points_used : 0.0}};
  }
  double global_ms_total = 0.0, global_ms_max = 0.0;
  for (double ms : s.global_ms) {
    global_ms_total += ms;
    global_ms_max = std::max(global_ms_max, ms);
  }
  j["global"] = {{"solves", s.global_solves},
                 {"rejected", s.global_rejected},
                 {"iterations", s.global_iterations},
                 {"ms_total", global_ms_total},
                 {"ms_max", global_ms_max},
                 {"loops_closed", s.loops_closed},
                 {"loops_prealigned", s.loops_prealigned},
                 {"loops_rejected", s.loops_rejected},
                 {"objects_reinitialized", s.objects_reinitialized},
                 // per global solve (the last one is the final solve): its time and its keyframes
                 {"solve_ms", s.global_ms},
                 {"solve_keyframes", s.global_keyframes}};
  j["faults"] = {{"imu_gaps", s.imu_gaps},
                 {"imu_gap_max_s", s.imu_gap_max_s},
                 {"imu_gap_links", s.imu_gap_links},
                 {"frame_gaps", s.frame_gaps},
                 {"frame_gap_max_s", s.frame_gap_max_s},
                 {"blind_stretches", s.blind_stretches},
                 {"blind_max_s", s.blind_max_s},
                 {"dead_reckoning_stretches", s.dead_reckoning_stretches},
                 {"dead_reckoning_max_s", s.dead_reckoning_max_s},
                 {"divergences", s.divergences},
                 {"resets", s.resets},
                 {"warnings", s.warnings}};
  return j;
}

void WriteJson(const nlohmann::ordered_json& json, const std::string& path) {
  WriteFileAtomically(path, "json", [&](std::ostream& out) { out << json.dump(2) << "\n"; });
}

}  // namespace fsp::apps
