// fsp render SCENE.yaml --out DIR [--seed N] [--duration S]: render a benchmark sequence with
// ground truth.
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <string>

#include "commands.h"
#include "fsp/common/error.h"
#include "fsp/sim/scene.h"
#include "fsp/sim/sequence_writer.h"

namespace fsp::apps {

namespace {

struct RenderArgs {
  std::string scene;
  std::string out;
  int64_t seed = -1;         // < 0: the scene's noise.seed
  double duration_s = -1.0;  // <= 0: the scene's duration_s
  sim::SequenceOptions options;
  bool no_images = false;
};

void RunRender(const RenderArgs& args) {
  sim::Scene scene = sim::LoadScene(args.scene);
  if (args.seed >= 0) scene.seed = static_cast<uint32_t>(args.seed);
  if (args.duration_s > 0.0) {
    if (args.duration_s > scene.trajectory.t_end()) {
      char msg[160];
      std::snprintf(msg, sizeof(msg), "--duration %g s is longer than the trajectory (%g s)",
                    args.duration_s, scene.trajectory.t_end());
      throw InputError(args.scene, 0, msg);
    }
    scene.duration_s = args.duration_s;
  }
  sim::SequenceOptions options = args.options;
  options.images = !args.no_images;
  const sim::SequenceSummary s = sim::WriteSequence(scene, args.out, options);
  std::printf("%s: %d frames %dx%d at %g Hz, %d IMU samples at %g Hz, %d objects\n",
              args.out.c_str(), s.frames, scene.camera.width, scene.camera.height,
              scene.camera_rate_hz, s.imu_samples, scene.imu.rate_hz, s.objects);
  std::printf(
      "flight: max speed %.2f m/s, max acceleration %.2f m/s^2, max angular rate %.1f deg/s\n",
      s.max_speed_mps, s.max_acc_mps2, s.max_rate_dps);
  std::printf("ground truth: %d corner rows, %d fully visible (observations_gt.csv)\n",
              s.observation_rows, s.fully_visible_rows);
  if (options.images) {
    std::printf("rendered in %.2f s: %.1f frames/s on %d threads\n", s.render_wall_s, s.render_fps,
                options.threads);
  } else {
    std::printf(
        "images not rendered (--no-images: one grey placeholder; gt-corners runs read no "
        "pixels)\n");
  }
  if (!s.top_view_path.empty()) std::printf("top view: %s\n", s.top_view_path.c_str());
}

}  // namespace

void AddRenderCommand(CLI::App& root) {
  auto args = std::make_shared<RenderArgs>();
  auto* sub = root.add_subcommand(
      "render",
      "Render a benchmark sequence from a scene file: EuRoC-layout images, IMU and ground truth,\n"
      "objects_gt.json, observations_gt.csv, video.mp4 + imu.csv + calib.yaml, top_view.png\n"
      "(scene file format: the comments of assets/scenes/default_room.yaml and\n"
      "sim/include/fsp/sim/scene.h)");
  sub->add_option("SCENE", args->scene, "scene file (YAML)")->required();
  sub->add_option("--out", args->out, "output folder (created)")->required();
  sub->add_option("--seed", args->seed,
                  "random seed of all noise (default: the scene's noise.seed)")
      ->check(CLI::Range(int64_t{0}, int64_t{0xffffffffLL}));
  sub->add_option("--duration", args->duration_s,
                  "seconds to render from t = 0 (default: the scene's duration_s)")
      ->check([](const std::string& text) {
        try {
          size_t used = 0;
          const double v = std::stod(text, &used);
          if (used == text.size() && v > 0.0 && std::isfinite(v)) return std::string();
        } catch (const std::exception&) {
        }
        return "must be a positive number of seconds, not '" + text + "'";
      });
  sub->add_option("--threads", args->options.threads,
                  "frames rendered in parallel (output does not depend on it)")
      ->check(CLI::Range(1, 64));
  sub->add_flag(
      "--no-images", args->no_images,
      "write IMU, ground truth and the top view only (no images, no video): much faster; the\n"
      "frame list names one grey placeholder image, enough for `fsp run --frontend gt-corners`");
  sub->add_flag("!--no-video", args->options.video, "do not write video.mp4");
  sub->callback([args] { RunRender(*args); });
}

}  // namespace fsp::apps
