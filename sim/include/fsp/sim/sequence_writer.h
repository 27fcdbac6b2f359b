// Writes a rendered sequence (docs/outputs.md): EuRoC layout with images, IMU and
// ground truth, objects_gt.json, observations_gt.csv, video.mp4 + imu.csv + calib.yaml, and
// top_view.png.
//
// Clock: t = 0 is frame 0 and IMU sample 0. Frame k is at round(k * 1e9 / camera rate) ns for every
// t < duration; IMU samples at round(k * 1e9 / imu rate) ns for t <= duration; ground-truth states
// at the IMU times. The video's frame clock (k / rate) therefore lines up with imu.csv.
//
// Determinism: every random draw comes from scene.seed: the IMU from std::seed_seq{seed, 1}, frame
// k's pixel noise from std::seed_seq{seed, 2, k}. Each frame's image depends only on its index and
// the seed, whatever the thread count, so the same scene and seed give byte-identical files.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "fsp/common/observations_io.h"
#include "fsp/sim/renderer.h"
#include "fsp/sim/scene.h"

namespace fsp::sim {

struct SequenceOptions {
  bool images = true;    // false: no images and no video (ground truth, IMU, top view only), fast:
                         // cam0/data.csv lists every frame with one grey placeholder image
                         // (cam0/data/no_pixels.png), so the sequence opens as a recording for the
                         // front ends that read no pixels (gt-corners, corners) and only for them
  bool video = true;     // also write video.mp4 (mp4v); imu.csv and calib.yaml are always written
  bool top_view = true;  // write top_view.png
  int threads = 2;       // frames rendered in parallel (the image of a frame does not depend on it)
  bool progress = true;  // progress bar on stderr (only drawn when stderr is a terminal)
  bool Check(std::string* why) const;
};

struct SequenceSummary {
  int frames = 0;
  int imu_samples = 0;
  int objects = 0;
  int observation_rows = 0;    // rows of observations_gt.csv
  int fully_visible_rows = 0;  // of which fully visible
  double render_wall_s = 0.0;  // wall time of rendering + writing the images and the video
  double render_fps = 0.0;     // frames / render_wall_s
  double max_speed_mps = 0.0;  // flight statistics (sampled at the IMU times)
  double max_acc_mps2 = 0.0;
  double max_rate_dps = 0.0;
  std::string top_view_path;  // empty when not written
};

// Writes the sequence into OUT_DIR (created; existing files of the same names are replaced, stale
// <t_ns>.png frames in mav0/cam0/data are removed). Throws InputError when the trajectory ends
// before scene.duration_s, or a file cannot be written.
SequenceSummary WriteSequence(const Scene& scene, const std::string& out_dir,
                              const SequenceOptions& options);

// Frame times of the sequence [ns]: round(k * 1e9 / rate) for t < duration.
std::vector<int64_t> FrameTimes(const Scene& scene);

// Ground-truth corner rows of one frame (camera pose T_W_C). A row is written for each object whose
// visible face points at the camera, whose 4 corners are at least 1 cm in front of it, and whose
// projection's bounding box overlaps the image. Corners: noise-free undistorted pixels (ideal
// pinhole). fully_visible: every corner inside the image after distortion and not occluded
// (renderer.PointVisible); RENDERER may be null (then occlusion is not checked).
std::vector<CornerRow> ProjectObjects(const Scene& scene, const Renderer* renderer,
                                      const Rigid3& T_W_C, int64_t t_ns);

// Frame k's pixel noise: v + sigma * n per pixel, rounded and clamped to 0..255 (CV_8UC1). n is the
// Irwin-Hall sum of four uniforms, centred and scaled to unit variance: nearly Gaussian (exact mean
// and variance, tails cut at 3.46 sigma) and several times cheaper than Box-Muller. The generator
// (SplitMix64, fully specified) starts from std::seed_seq{seed, 2, k}: the noise depends only on
// the seed and the frame index. sigma <= 0: no change.
void AddPixelNoise(double sigma, uint32_t seed, int frame_index, cv::Mat* image);

// Top view of the room (x right, y up), each object as a labelled segment "id class", the
// trajectory coloured by time with a colour bar, the start marked. About width_px wide.
cv::Mat DrawTopView(const Scene& scene, int width_px = 1200);

}  // namespace fsp::sim
