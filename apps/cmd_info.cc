// fsp info INPUT [--calib FILE] [--imu FILE] [--frame-times FILE] [--json] [--quick]: what a
// recording holds (frames, IMU samples, time span, calibration), after decoding every image unless
// --quick.
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "fsp/common/dataset.h"
#include "fsp/common/progress.h"
#include "fsp/common/time.h"

namespace fsp::apps {

namespace {

struct InfoArgs {
  SourceOptions source;
  bool json = false;
  bool quick = false;
};

nlohmann::ordered_json ToJson(const Source& src, const SourceSummary& s, const InfoArgs& args,
                              int decoded) {
  const Calibration& c = src.calibration();
  nlohmann::ordered_json j;
  j["frames"] = s.frames;
  j["imu_samples"] = s.imu_samples;
  j["t_first_ns"] = s.t_first_ns;
  j["t_last_ns"] = s.t_last_ns;
  j["camera"] = {{"width", c.camera.width},
                 {"height", c.camera.height},
                 {"fx", c.camera.fx},
                 {"fy", c.camera.fy},
                 {"cx", c.camera.cx},
                 {"cy", c.camera.cy},
                 {"distortion", c.camera.distortion},
                 {"rate_hz", c.camera_rate_hz}};
  const Mat4 M = c.T_B_C.Matrix();
  nlohmann::ordered_json t = nlohmann::ordered_json::array();
  for (int r = 0; r < 4; ++r)
    for (int col = 0; col < 4; ++col) t.push_back(M(r, col));
  j["T_B_C"] = t;
  j["kind"] = ToString(s.kind);
  j["input"] = args.source.input;
  j["calibration"] = c.source;
  j["imu_noise_source"] = c.imu_source.empty() ? "defaults" : c.imu_source;
  j["time_offset_ns"] = c.time_offset_ns;
  j["duration_s"] = NsToSeconds(s.t_last_ns - s.t_first_ns);
  j["frame_rate_hz"] = s.frame_rate_hz;
  j["imu"] = {{"t_first_ns", s.imu_t_first_ns},
              {"t_last_ns", s.imu_t_last_ns},
              {"rate_hz", s.imu_rate_hz},
              {"largest_gap_s", NsToSeconds(s.largest_imu_gap_ns)},
              {"largest_gap_at_ns", s.largest_imu_gap_at_ns},
              {"gaps", s.imu_gaps},
              {"gyroscope_noise_density", c.imu.gyroscope_noise_density},
              {"accelerometer_noise_density", c.imu.accelerometer_noise_density},
              {"gyroscope_random_walk", c.imu.gyroscope_random_walk},
              {"accelerometer_random_walk", c.imu.accelerometer_random_walk}};
  j["frames_outside_imu"] = s.frames_outside_imu;
  j["frames_decoded"] = decoded;
  return j;
}

void PrintHuman(const Source& src, const SourceSummary& s, const InfoArgs& args, int decoded) {
  const Calibration& c = src.calibration();
  const PinholeRadtan& k = c.camera;
  std::printf("input        %s (%s)\n", args.source.input.c_str(), ToString(s.kind));
  std::printf("calibration  %s\n", c.source.c_str());
  std::printf("frames       %d, t %lld .. %lld ns (%.3f s, %.2f Hz)\n", s.frames,
              static_cast<long long>(s.t_first_ns), static_cast<long long>(s.t_last_ns),
              NsToSeconds(s.t_last_ns - s.t_first_ns), s.frame_rate_hz);
  if (c.time_offset_ns != 0) {
    std::printf("             (camera clock shifted by time_offset_ns = %lld)\n",
                static_cast<long long>(c.time_offset_ns));
  }
  std::printf("imu          %d samples, t %lld .. %lld ns (%.3f s, %.1f Hz)\n", s.imu_samples,
              static_cast<long long>(s.imu_t_first_ns), static_cast<long long>(s.imu_t_last_ns),
              NsToSeconds(s.imu_t_last_ns - s.imu_t_first_ns), s.imu_rate_hz);
  std::printf(
      "             largest gap %.1f ms (ending at %lld ns); %d gaps longer than 5 periods\n",
      1e3 * NsToSeconds(s.largest_imu_gap_ns), static_cast<long long>(s.largest_imu_gap_at_ns),
      s.imu_gaps);
  std::printf(
      "camera       %dx%d, fx %.6g fy %.6g cx %.6g cy %.6g, distortion [%.10g, %.10g, %.10g, "
      "%.10g], %.6g Hz\n",
      k.width, k.height, k.fx, k.fy, k.cx, k.cy, k.distortion[0], k.distortion[1], k.distortion[2],
      k.distortion[3], c.camera_rate_hz);
  const Mat4 M = c.T_B_C.Matrix();
  for (int r = 0; r < 4; ++r) {
    std::printf("%s [%12.9f %12.9f %12.9f %12.9f]\n", r == 0 ? "T_B_C       " : "            ",
                M(r, 0), M(r, 1), M(r, 2), M(r, 3));
  }
  std::printf(
      "imu noise    gyro %.4g rad/s/sqrt(Hz), acc %.4g m/s^2/sqrt(Hz), gyro walk %.4g, acc walk "
      "%.4g, "
      "%.6g Hz (%s)\n",
      c.imu.gyroscope_noise_density, c.imu.accelerometer_noise_density, c.imu.gyroscope_random_walk,
      c.imu.accelerometer_random_walk, c.imu.rate_hz,
      c.imu_source.empty() ? "defaults" : c.imu_source.c_str());
  if (args.quick) {
    std::printf("images       not decoded (--quick; the first one was checked)\n");
  } else {
    std::printf("images       %d decoded, all %dx%d 8-bit grey\n", decoded, k.width, k.height);
  }
  if (s.frames_outside_imu > 0) {
    std::printf("warning      %d frames lie outside the IMU time span\n", s.frames_outside_imu);
  }
  if (s.imu_gaps > 0)
    std::printf("warning      the IMU stream has %d gaps longer than 5 periods\n", s.imu_gaps);
}

void RunInfo(const InfoArgs& args) {
  SourceOptions opts = args.source;
  opts.decode_images = false;
  std::unique_ptr<Source> src = OpenSource(opts);
  const SourceSummary s = Summarize(*src);
  int decoded = 0;
  if (!args.quick) {
    Progress progress("decoding images", s.frames);
    for (int i = 0; i < s.frames; ++i) {
      src->ReadFrame(i);  // throws InputError naming the image
      progress.Update(++decoded);
    }
  }
  if (args.json) {
    std::cout << ToJson(*src, s, args, decoded).dump(2) << "\n";
  } else {
    PrintHuman(*src, s, args, decoded);
  }
}

}  // namespace

void AddInfoCommand(CLI::App& root) {
  auto args = std::make_shared<InfoArgs>();
  auto* sub = root.add_subcommand(
      "info", "Describe a recording: frames, IMU samples, time span, calibration");
  sub->footer(
      "INPUT is a EuRoC folder (DIR/mav0 or mav0 itself), a DSO / TUM-VI / DM-VIO folder\n"
      "(cam0/{times.txt,camera.txt,images/}, imu.txt, camchain.yaml), a video file (with --imu "
      "and\n"
      "--calib), or a folder of images named <t_ns>.png or listed in a data.csv (with --imu and\n"
      "--calib). Every image is decoded to verify it unless --quick. Bad input: one line 'fsp: "
      "error: FILE:LINE: what' and exit "
      "code 2.");
  sub->add_option("INPUT", args->source.input,
                  "EuRoC or DSO dataset folder, video file or image folder")
      ->required();
  sub->add_option(
      "--calib", args->source.calib,
      "calibration: EuRoC cam0/sensor.yaml, Kalibr camchain or fsp calib.yaml (overrides EuRoC's)");
  sub->add_option("--imu", args->source.imu,
                  "IMU csv t_ns,wx,wy,wz,ax,ay,az (overrides EuRoC's imu0/data.csv)");
  sub->add_option(
      "--frame-times", args->source.frame_times,
      "video only: one t_ns per frame (plain or csv first column), instead of the video clock");
  sub->add_flag("--json", args->json,
                "print one JSON object (frames, imu_samples, t_first_ns, t_last_ns, camera, T_B_C) "
                "instead of a report");
  sub->add_flag("--quick", args->quick, "do not decode every image (only the first)");
  sub->callback([args] { RunInfo(*args); });
}

}  // namespace fsp::apps
