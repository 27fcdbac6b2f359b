// Input sources on real EuRoC data and on small recordings of every kind written here.
#include <random>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "dataset_fixtures.h"
#include "fsp/common/dataset.h"
#include "test_util.h"

namespace fsp {
namespace {

namespace fs = std::filesystem;
using test::ErrorOf;

// Drains SOURCE, checking the merge order: time never decreases, and when a frame comes out every
// IMU sample with t <= frame t has come out before it. Returns {frames, imu samples}.
std::pair<int, int> DrainInOrder(Source* source) {
  const std::vector<ImuSample>& imu = source->imu();
  int frames = 0, samples = 0;
  int64_t last = std::numeric_limits<int64_t>::min();
  while (auto m = source->Next()) {
    if (const auto* s = std::get_if<ImuSample>(&*m)) {
      EXPECT_GE(s->t_ns, last);
      last = s->t_ns;
      ++samples;
    } else {
      const Frame& f = std::get<Frame>(*m);
      EXPECT_GE(f.t_ns, last);
      last = f.t_ns;
      EXPECT_EQ(f.index, frames);
      const auto upto = std::upper_bound(imu.begin(), imu.end(), f.t_ns,
                                         [](int64_t t, const ImuSample& x) { return t < x.t_ns; });
      EXPECT_EQ(samples, upto - imu.begin()) << "frame " << f.index;
      ++frames;
    }
  }
  return {frames, samples};
}

Mat4 EurocTBS() {
  Mat4 M;
  M << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,  //
      0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,       //
      -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,   //
      0.0, 0.0, 0.0, 1.0;
  return M;
}

TEST(Dataset, EurocMicro) {
  FSP_REQUIRE_TEST_DATA(dir, "euroc_v101_micro");
  SourceOptions opts;
  opts.input = dir;
  opts.decode_images = false;
  auto src = OpenSource(opts);
  EXPECT_EQ(src->kind(), InputKind::kEuroc);
  EXPECT_EQ(src->frame_times().size(), 95u);
  EXPECT_EQ(src->imu().size(), 29120u);
  EXPECT_EQ(src->frame_times().front(), 1403715273262142976LL);
  EXPECT_EQ(src->frame_times().back(), 1403715277962142976LL);
  const Calibration& c = src->calibration();
  EXPECT_DOUBLE_EQ(c.camera.fx, 458.654);
  EXPECT_LT((c.T_B_C.Matrix() - EurocTBS()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_DOUBLE_EQ(c.imu.gyroscope_noise_density, 1.6968e-04);  // from imu0/sensor.yaml
  EXPECT_EQ(c.imu_source, dir + "/mav0/imu0/sensor.yaml");
  const ImuSample& s0 = src->imu().front();
  EXPECT_EQ(s0.t_ns, 1403715273262142976LL);
  EXPECT_DOUBLE_EQ(s0.gyro.x(), -0.0020943951023931952);
  EXPECT_DOUBLE_EQ(s0.acc.z(), -3.6938381666666662);

  const Frame f = src->ReadFrame(94);
  EXPECT_EQ(f.image.type(), CV_8UC1);
  EXPECT_EQ(f.image.cols, 752);
  EXPECT_EQ(f.image.rows, 480);
  EXPECT_EQ(f.source, dir + "/mav0/cam0/data/1403715277962142976.png");

  const auto [frames, samples] = DrainInOrder(src.get());
  EXPECT_EQ(frames, 95);
  EXPECT_EQ(samples, 29120);

  const SourceSummary sum = Summarize(*src);
  EXPECT_NEAR(sum.frame_rate_hz, 20.0, 1e-3);
  EXPECT_NEAR(sum.imu_rate_hz, 200.0, 0.1);
  EXPECT_EQ(sum.frames_outside_imu, 0);

  // The mav0 folder itself is the same input.
  opts.input = dir + "/mav0";
  EXPECT_EQ(OpenSource(opts)->frame_times().size(), 95u);
}

TEST(Dataset, EurocMicroWithKalibrCalibration) {
  FSP_REQUIRE_TEST_DATA(dir, "euroc_v101_micro");
  FSP_REQUIRE_TEST_DATA(kalibr, "vio_calibration/euroc_kalibr_openvins/kalibr_imucam_chain.yaml");
  SourceOptions opts;
  opts.input = dir;
  opts.calib = kalibr;
  opts.decode_images = false;
  auto src = OpenSource(opts);
  EXPECT_EQ(src->calibration().source, kalibr);
  EXPECT_LT((src->calibration().T_B_C.Matrix() - EurocTBS()).cwiseAbs().maxCoeff(), 1e-6);
}

// The micro dataset's cam0 folder as an image folder: by its data.csv, and its data/ folder by file
// names (19-digit nanosecond timestamps).
TEST(Dataset, EurocMicroAsImageFolder) {
  FSP_REQUIRE_TEST_DATA(mav0, "euroc_v101_micro/mav0");
  SourceOptions opts;
  opts.calib = mav0 + "/cam0/sensor.yaml";
  opts.imu = mav0 + "/imu0/data.csv";
  opts.decode_images = false;
  for (const std::string& input : {mav0 + "/cam0", mav0 + "/cam0/data"}) {
    opts.input = input;
    auto src = OpenSource(opts);
    EXPECT_EQ(src->kind(), InputKind::kImageFolder);
    ASSERT_EQ(src->frame_times().size(), 95u) << input;
    EXPECT_EQ(src->frame_times()[1], 1403715273312143104LL) << input;
    EXPECT_EQ(src->ReadFrame(1).source, mav0 + "/cam0/data/1403715273312143104.png") << input;
  }
}

TEST(Dataset, InfoJsonOnEurocMicro) {
  FSP_REQUIRE_TEST_DATA(dir, "euroc_v101_micro");
  const auto r = test::RunFsp("info '" + dir + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("frames").get<int>(), 95);
  EXPECT_EQ(j.at("imu_samples").get<int>(), 29120);
  EXPECT_EQ(j.at("t_first_ns").get<int64_t>(), 1403715273262142976LL);
  EXPECT_EQ(j.at("t_last_ns").get<int64_t>(), 1403715277962142976LL);
  const auto& cam = j.at("camera");
  EXPECT_EQ(cam.at("width").get<int>(), 752);
  EXPECT_EQ(cam.at("height").get<int>(), 480);
  EXPECT_DOUBLE_EQ(cam.at("fx").get<double>(), 458.654);
  EXPECT_DOUBLE_EQ(cam.at("fy").get<double>(), 457.296);
  EXPECT_DOUBLE_EQ(cam.at("cx").get<double>(), 367.215);
  EXPECT_DOUBLE_EQ(cam.at("cy").get<double>(), 248.375);
  ASSERT_EQ(cam.at("distortion").size(), 4u);
  EXPECT_DOUBLE_EQ(cam.at("distortion")[0].get<double>(), -0.28340811);
  ASSERT_EQ(j.at("T_B_C").size(), 16u);
  const Mat4 T = EurocTBS();
  for (int i = 0; i < 16; ++i)
    EXPECT_NEAR(j.at("T_B_C")[i].get<double>(), T(i / 4, i % 4), 1e-9) << i;
  EXPECT_EQ(j.at("frames_decoded").get<int>(), 95);

  const auto human = test::RunFsp("info '" + dir + "' --quick");
  ASSERT_EQ(human.exit_code, 0) << human.err;
  EXPECT_NE(human.out.find("95, t 1403715273262142976"), std::string::npos) << human.out;
  EXPECT_NE(human.out.find("29120 samples"), std::string::npos) << human.out;
  EXPECT_NE(human.out.find("fx 458.654"), std::string::npos) << human.out;
}

TEST(Dataset, ImuCsvRoundTrip) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 3.0);
  std::vector<ImuSample> imu;
  for (int i = 0; i < 500; ++i) {
    ImuSample s;
    s.t_ns = 1403715273262142976LL + 5'000'123LL * i;
    s.gyro = Vec3(n(rng), n(rng), n(rng)) * 1e-3;
    s.acc = Vec3(n(rng), n(rng), n(rng) + 9.81);
    imu.push_back(s);
  }
  const auto path = (test::ScratchDir() / "imu.csv").string();
  WriteImuCsv(imu, path);
  const std::vector<ImuSample> back = ReadImuCsv(path);
  ASSERT_EQ(back.size(), imu.size());
  for (size_t i = 0; i < imu.size(); ++i) {
    EXPECT_EQ(back[i].t_ns, imu[i].t_ns);
    EXPECT_EQ(back[i].gyro, imu[i].gyro);  // bit-identical
    EXPECT_EQ(back[i].acc, imu[i].acc);
  }
}

// A video written with cv::VideoWriter (mp4v, 20 fps) + IMU csv + calib.yaml: frame k at k * 50 ms.
TEST(Dataset, VideoTriple) {
  const auto dir = test::ScratchDir();
  const auto video = (dir / "video.mp4").string();
  {
    cv::VideoWriter writer(video, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), 20.0,
                           cv::Size(test::kW, test::kH));
    ASSERT_TRUE(writer.isOpened());
    for (int k = 0; k < 10; ++k) {
      cv::Mat bgr;
      cv::cvtColor(test::TestImage(k), bgr, cv::COLOR_GRAY2BGR);
      writer.write(bgr);
    }
  }
  WriteImuCsv(test::TestImu(0, 600'000'000), (dir / "imu.csv").string());
  WriteCalibration(test::TestCalibration(), (dir / "calib.yaml").string());
  SourceOptions opts;
  opts.input = video;
  opts.imu = (dir / "imu.csv").string();
  opts.calib = (dir / "calib.yaml").string();
  auto src = OpenSource(opts);
  EXPECT_EQ(src->kind(), InputKind::kVideo);
  ASSERT_EQ(src->frame_times().size(), 10u);
  for (int k = 0; k < 10; ++k)
    EXPECT_EQ(src->frame_times()[static_cast<size_t>(k)], 50'000'000LL * k) << k;

  // Random access, forwards and backwards, gives the same pixels as a sequential pass.
  const Frame f5 = src->ReadFrame(5);
  const Frame f2 = src->ReadFrame(2);
  EXPECT_EQ(f5.image.type(), CV_8UC1);
  EXPECT_EQ(f5.image.size(), cv::Size(test::kW, test::kH));
  EXPECT_EQ(f5.source, video + "#frame=5");
  EXPECT_EQ(f2.t_ns, 100'000'000);
  // mp4v is lossy: compare with the written image loosely, and frames with each other strictly.
  EXPECT_LT(cv::norm(f2.image, test::TestImage(2), cv::NORM_L1) / (test::kW * test::kH), 6.0);
  EXPECT_GT(cv::norm(f5.image, f2.image, cv::NORM_L1) / (test::kW * test::kH), 10.0);
  int frames = 0;
  while (auto m = src->Next()) {
    if (const auto* f = std::get_if<Frame>(&*m)) {
      if (f->index == 5) {
        EXPECT_EQ(cv::norm(f->image, f5.image, cv::NORM_INF), 0.0);
      }
      ++frames;
    }
  }
  EXPECT_EQ(frames, 10);

  // --frame-times overrides the clock; the calibration's time offset shifts every frame.
  std::string times;
  for (int k = 0; k < 10; ++k) times += std::to_string(1000 + 33'000'000LL * k) + "\n";
  test::WriteText(dir / "times.txt", times);
  Calibration shifted = test::TestCalibration();
  shifted.time_offset_ns = 7;
  WriteCalibration(shifted, (dir / "shifted.yaml").string());
  opts.frame_times = (dir / "times.txt").string();
  opts.calib = (dir / "shifted.yaml").string();
  auto timed = OpenSource(opts);
  EXPECT_EQ(timed->frame_times()[3], 1000 + 99'000'000 + 7);

  // A count mismatch is an error naming both files.
  test::WriteText(dir / "nine.txt", times.substr(0, times.rfind('\n', times.size() - 2) + 1));
  opts.frame_times = (dir / "nine.txt").string();
  const std::string msg = ErrorOf([&] { OpenSource(opts); });
  EXPECT_NE(msg.find("nine.txt: 9 frame times but " + video + " has 10 frames"), std::string::npos)
      << msg;

  // fsp info on the triple.
  const auto r = test::RunFsp("info '" + video + "' --imu '" + opts.imu + "' --calib '" +
                              (dir / "calib.yaml").string() + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("frames").get<int>(), 10);
  EXPECT_EQ(j.at("t_last_ns").get<int64_t>(), 450'000'000);
  EXPECT_EQ(j.at("kind").get<std::string>(), "video");
}

// A constant-rate video gets the renderer's exact frame times round(k * 1e9 / fps), also at 30 Hz.
TEST(Dataset, VideoAt30HzHasExactNanosecondTimes) {
  const auto dir = test::ScratchDir();
  const auto video = (dir / "video.mp4").string();
  {
    cv::VideoWriter writer(video, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), 30.0,
                           cv::Size(test::kW, test::kH), false);
    ASSERT_TRUE(writer.isOpened());
    for (int k = 0; k < 4; ++k) writer.write(test::TestImage(k));
  }
  WriteImuCsv(test::TestImu(0, 200'000'000), (dir / "imu.csv").string());
  WriteCalibration(test::TestCalibration(), (dir / "calib.yaml").string());
  SourceOptions opts;
  opts.input = video;
  opts.imu = (dir / "imu.csv").string();
  opts.calib = (dir / "calib.yaml").string();
  auto src = OpenSource(opts);
  EXPECT_EQ(src->frame_times(), (std::vector<int64_t>{0, 33'333'333, 66'666'667, 100'000'000}));
}

// Images named by their timestamps, colour or grey, any supported extension.
TEST(Dataset, ImageFolderNamedByTimestamps) {
  const auto dir = test::ScratchDir();
  const auto images = dir / "images";
  fs::create_directories(images);
  const std::vector<int64_t> t = {1'000'000'000, 1'050'000'000, 1'100'000'000};
  cv::imwrite((images / "1000000000.png").string(), test::TestImage(0));
  cv::Mat colour;
  cv::cvtColor(test::TestImage(1), colour, cv::COLOR_GRAY2BGR);
  cv::imwrite((images / "1050000000.bmp").string(), colour);
  cv::imwrite((images / "1100000000.pgm").string(), test::TestImage(2));
  test::WriteText(images / "notes.txt", "not an image, ignored\n");
  WriteImuCsv(test::TestImu(900'000'000, 1'200'000'000), (dir / "imu.csv").string());
  WriteCalibration(test::TestCalibration(), (dir / "calib.yaml").string());
  SourceOptions opts;
  opts.input = images.string();
  opts.imu = (dir / "imu.csv").string();
  opts.calib = (dir / "calib.yaml").string();
  auto src = OpenSource(opts);
  EXPECT_EQ(src->kind(), InputKind::kImageFolder);
  EXPECT_EQ(src->frame_times(), t);
  const Frame f1 = src->ReadFrame(1);
  EXPECT_EQ(f1.image.type(), CV_8UC1);  // colour converted to grey
  EXPECT_EQ(cv::norm(f1.image, test::TestImage(1), cv::NORM_INF), 0.0);
  const auto [frames, samples] = DrainInOrder(src.get());
  EXPECT_EQ(frames, 3);
  EXPECT_EQ(samples, 61);
}

// Images listed in a data.csv: beside it, or in a data/ subfolder (EuRoC cam0 style).
TEST(Dataset, ImageFolderWithDataCsv) {
  const auto dir = test::ScratchDir();
  WriteImuCsv(test::TestImu(0, 1'000'000'000), (dir / "imu.csv").string());
  WriteCalibration(test::TestCalibration(), (dir / "calib.yaml").string());
  for (const bool sub : {false, true}) {
    const auto folder = dir / (sub ? "cam0" : "flat");
    const auto image_dir = sub ? folder / "data" : folder;
    fs::create_directories(image_dir);
    std::string csv = "#timestamp [ns],filename\n";
    for (int k = 0; k < 4; ++k) {
      const std::string name = "frame_" + std::to_string(k) + ".jpg";
      cv::imwrite((image_dir / name).string(), test::TestImage(k));
      csv += std::to_string(100'000'000LL * (k + 1)) + "," + name + "\n";
    }
    test::WriteText(folder / "data.csv", csv);
    SourceOptions opts;
    opts.input = folder.string();
    opts.imu = (dir / "imu.csv").string();
    opts.calib = (dir / "calib.yaml").string();
    auto src = OpenSource(opts);
    EXPECT_EQ(src->kind(), InputKind::kImageFolder);
    ASSERT_EQ(src->frame_times().size(), 4u);
    EXPECT_EQ(src->frame_times()[2], 300'000'000);
    EXPECT_EQ(src->ReadFrame(3).source, (image_dir / "frame_3.jpg").string());
  }
}

// A EuRoC layout with --calib and --imu overriding its own files; IMU gaps reported in the summary.
TEST(Dataset, EurocOverridesAndImuGaps) {
  const auto dir = test::ScratchDir();
  const std::vector<int64_t> t = test::MakeEuroc(dir / "seq");
  SourceOptions opts;
  opts.input = (dir / "seq").string();
  auto src = OpenSource(opts);
  EXPECT_EQ(src->frame_times(), t);
  EXPECT_DOUBLE_EQ(src->calibration().camera.distortion[1], -0.002);
  EXPECT_DOUBLE_EQ(src->calibration().imu.gyroscope_noise_density, 1.0e-4);
  EXPECT_EQ(Summarize(*src).imu_gaps, 0);

  Calibration calib = test::TestCalibration();
  calib.camera.fx = 31.5;
  WriteCalibration(calib, (dir / "calib.yaml").string());
  std::vector<ImuSample> imu = test::TestImu(t.front() - 100'000'000, t.back());
  imu.erase(imu.begin() + 30, imu.begin() + 50);  // a 105 ms hole
  WriteImuCsv(imu, (dir / "imu.csv").string());
  opts.calib = (dir / "calib.yaml").string();
  opts.imu = (dir / "imu.csv").string();
  src = OpenSource(opts);
  EXPECT_EQ(src->calibration().camera.fx, 31.5);
  EXPECT_EQ(src->calibration().imu_source, opts.calib);  // our calib.yaml carries IMU noise
  EXPECT_EQ(src->imu().size(), imu.size());
  const SourceSummary s = Summarize(*src);
  EXPECT_EQ(s.imu_gaps, 1);
  EXPECT_EQ(s.largest_imu_gap_ns, 105'000'000);
  EXPECT_EQ(s.largest_imu_gap_at_ns, imu[30].t_ns);
}

}  // namespace
}  // namespace fsp
