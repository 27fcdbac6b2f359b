// Render speed on a room scene like the default one: a 10 x 8 x 3 m room (6 textured surfaces) with
// 20 objects (doors, windows, cabinets, posters, tags), 640 x 480 with EuRoC-like distortion, one
// thread.
//
//   bench_render [--write_png=PREFIX] [Google Benchmark flags]
//
// --write_png writes PREFIX_<k>.png for a few of the benchmark's poses (supersampling 2) and
// PREFIX_blur.png (motion blur, 16 poses), to look at.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/imgcodecs.hpp>

#include "fsp/sim/renderer.h"

namespace fsp::sim {
namespace {

PinholeRadtan Camera640() {
  PinholeRadtan cam;
  cam.width = 640;
  cam.height = 480;
  cam.fx = cam.fy = 458.0;
  cam.cx = 320.0;
  cam.cy = 240.0;
  cam.distortion = {-0.28, 0.074, 2e-4, 2e-5};
  return cam;
}

// Walls of the room x in [0, 10], y in [0, 8], z in [0, 3], as (origin, axis_u) along the floor
// with axis_v = up; each normal u x v points into the room.
struct WallFrame {
  Vec3 origin, dir;  // dir: unit vector along the wall, to the right when facing it from inside
  double length;
};

const WallFrame kWalls[4] = {{{0, 8, 0}, {1, 0, 0}, 10},    // north, facing -y
                             {{10, 8, 0}, {0, -1, 0}, 8},   // east, facing -x
                             {{10, 0, 0}, {-1, 0, 0}, 10},  // south, facing +y
                             {{0, 0, 0}, {0, 1, 0}, 8}};    // west, facing +x

std::vector<TexturedQuad> RoomScene() {
  std::vector<TexturedQuad> quads;
  auto add = [&](int id, const Vec3& o, const Vec3& u, const Vec3& v, TextureKind kind,
                 int tag = 0) {
    TexturedQuad q;
    q.id = id;
    q.origin_W = o;
    q.axis_u_W = u;
    q.axis_v_W = v;
    q.texture = kind;
    q.tag_id = tag;
    q.seed = static_cast<uint32_t>(100 + quads.size());
    quads.push_back(q);
  };
  add(-1, {0, 0, 0}, {10, 0, 0}, {0, 8, 0}, TextureKind::kFloor);
  add(-1, {0, 0, 3}, {0, 8, 0}, {10, 0, 0}, TextureKind::kCeiling);
  for (const WallFrame& w : kWalls)
    add(-1, w.origin, w.length * w.dir, {0, 0, 3}, TextureKind::kWall);
  struct Obj {
    int wall;
    double s, z, w, h;
    TextureKind kind;
  };
  const Obj objs[] = {{0, 1.0, 0.0, 0.9, 2.1, TextureKind::kWood},
                      {0, 3.5, 0.9, 1.4, 1.3, TextureKind::kGlass},
                      {0, 6.0, 1.2, 0.6, 0.8, TextureKind::kPoster},
                      {0, 7.3, 1.4, 0.2, 0.2, TextureKind::kTag},
                      {0, 8.2, 0.0, 1.2, 0.9, TextureKind::kCabinet},
                      {0, 5.3, 1.6, 0.12, 0.12, TextureKind::kTag},
                      {1, 1.5, 0.9, 1.2, 1.3, TextureKind::kGlass},
                      {1, 4.0, 1.3, 0.7, 0.5, TextureKind::kPoster},
                      {1, 5.3, 1.5, 0.3, 0.3, TextureKind::kTag},
                      {1, 6.5, 0.0, 0.9, 2.1, TextureKind::kWood},
                      {2, 1.0, 0.0, 0.8, 1.8, TextureKind::kCabinet},
                      {2, 3.0, 1.2, 1.0, 0.7, TextureKind::kPoster},
                      {2, 5.0, 0.9, 1.6, 1.2, TextureKind::kGlass},
                      {2, 7.0, 1.5, 0.15, 0.15, TextureKind::kTag},
                      {2, 8.2, 0.0, 0.9, 2.1, TextureKind::kWood},
                      {3, 1.0, 1.3, 0.5, 0.7, TextureKind::kPoster},
                      {3, 2.5, 0.0, 1.0, 0.8, TextureKind::kCabinet},
                      {3, 4.5, 1.4, 0.25, 0.25, TextureKind::kTag},
                      {3, 5.8, 0.9, 1.2, 1.4, TextureKind::kGlass},
                      {3, 7.2, 1.2, 0.6, 0.6, TextureKind::kPoster}};
  int id = 1;
  for (const Obj& o : objs) {
    const WallFrame& w = kWalls[o.wall];
    add(id, w.origin + o.s * w.dir + Vec3(0, 0, o.z), o.w * w.dir, {0, 0, o.h}, o.kind, id);
    ++id;
  }
  return quads;
}

// 16 poses on an ellipse around the room's centre at 1.5 m height, looking outwards at the walls.
std::vector<Rigid3> Poses() {
  std::vector<Rigid3> poses;
  for (int k = 0; k < 16; ++k) {
    const double a = 2.0 * M_PI * k / 16.0;
    const Vec3 eye(5.0 + 2.5 * std::cos(a), 4.0 + 1.8 * std::sin(a), 1.5 + 0.2 * std::sin(3 * a));
    const double yaw = a + 0.4 * std::sin(2 * a);
    const Vec3 z(std::cos(yaw), std::sin(yaw), -0.15);  // forward, slightly down
    const Vec3 zc = z.normalized();
    const Vec3 xc = zc.cross(Vec3::UnitZ()).normalized();
    Mat3 R;
    R << xc, zc.cross(xc), zc;
    poses.emplace_back(R, eye);
  }
  return poses;
}

// One renderer per supersampling factor, shared by the benchmark's threads (Render is const and
// thread-safe, as `fsp render` uses it).
const Renderer& SharedRenderer(int supersampling) {
  static const Renderer r1 = [] {
    RenderOptions o;
    o.supersampling = 1;
    return Renderer(Camera640(), RoomScene(), o);
  }();
  static const Renderer r2 = [] {
    RenderOptions o;
    o.supersampling = 2;
    return Renderer(Camera640(), RoomScene(), o);
  }();
  return supersampling == 1 ? r1 : r2;
}

void BM_Render(benchmark::State& state) {
  const Renderer& renderer = SharedRenderer(static_cast<int>(state.range(0)));
  const std::vector<Rigid3> poses = Poses();
  size_t k = static_cast<size_t>(state.thread_index()) * 5;
  for (auto _ : state) {
    cv::Mat img = renderer.Render(poses[k++ % poses.size()]);
    benchmark::DoNotOptimize(img.data);
  }
  // Summed over threads, divided by wall time: the frames per second of all threads together.
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Render)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Render)->Arg(2)->Threads(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Motion blur with 4 or 16 poses per frame at supersampling 2: the poses share each pixel's rays
// (4 poses cost one render, 16 poses four).
void BM_RenderBlur(benchmark::State& state) {
  RenderOptions opt;
  opt.motion_blur_samples = static_cast<int>(state.range(0));
  const Renderer renderer(Camera640(), RoomScene(), opt);
  const std::vector<Rigid3> poses = Poses();
  size_t k = 0;
  for (auto _ : state) {
    const Rigid3& open = poses[k++ % poses.size()];
    const Rigid3 close(open.R() * RotY(0.05), open.translation());
    cv::Mat img = renderer.Render(open, close);
    benchmark::DoNotOptimize(img.data);
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderBlur)->Arg(4)->Arg(16)->Unit(benchmark::kMillisecond)->UseRealTime();

// Construction: texture generation and the per-pixel ray table (once per `fsp render`).
void BM_Construct(benchmark::State& state) {
  for (auto _ : state) {
    Renderer renderer(Camera640(), RoomScene(), RenderOptions{});
    benchmark::DoNotOptimize(&renderer);
  }
}
BENCHMARK(BM_Construct)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();

}  // namespace
}  // namespace fsp::sim

int main(int argc, char** argv) {
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    const char* flag = "--write_png=";
    if (std::strncmp(argv[i], flag, std::strlen(flag)) == 0) {
      const std::string prefix = argv[i] + std::strlen(flag);
      const fsp::sim::Renderer renderer(fsp::sim::Camera640(), fsp::sim::RoomScene(),
                                        fsp::sim::RenderOptions{});
      const auto poses = fsp::sim::Poses();
      for (size_t k = 0; k < poses.size(); k += 2)
        cv::imwrite(prefix + "_" + std::to_string(k) + ".png", renderer.Render(poses[k]));
      // Motion blur: 16 poses over a 0.05 rad yaw (about 20 px of motion at the image centre).
      fsp::sim::RenderOptions blur;
      blur.motion_blur_samples = 16;
      const fsp::sim::Renderer blurred(fsp::sim::Camera640(), fsp::sim::RoomScene(), blur);
      const fsp::Rigid3 close(poses[0].R() * fsp::RotY(0.05), poses[0].translation());
      cv::imwrite(prefix + "_blur.png", blurred.Render(poses[0], close));
      continue;
    }
    args.push_back(argv[i]);
  }
  int n = static_cast<int>(args.size());
  benchmark::Initialize(&n, args.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
