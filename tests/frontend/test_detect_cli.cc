// `fsp detect` end to end: outputs, and clear errors on bad input.
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "synthetic.h"
#include "test_util.h"

namespace fsp::test {
namespace {

int CountLines(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

TEST(DetectCli, WritesCsvAndDrawnPng) {
  const auto dir = ScratchDir();
  const SyntheticFrame fr = MakeSyntheticFrame(4);
  cv::imwrite((dir / "frame.png").string(), fr.image);
  const auto r =
      RunFsp("detect " + (dir / "frame.png").string() + " --out " + (dir / "out").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(CountLines(r.out), 1) << r.out;  // one summary line per image
  EXPECT_NE(r.out.find("4 rectangles"), std::string::npos) << r.out;
  const std::string csv = test::Slurp(dir / "out" / "detections.csv");
  EXPECT_EQ(csv.rfind("image,tag_id,class,u1,v1,u2,v2,u3,v3,u4,v4,score\n", 0), 0u) << csv;
  EXPECT_EQ(CountLines(csv), 5) << csv;
  EXPECT_NE(csv.find("frame.png,-1,"), std::string::npos);
  const cv::Mat drawn = cv::imread((dir / "out" / "frame_detect.png").string());
  ASSERT_FALSE(drawn.empty());
  EXPECT_EQ(drawn.cols, 640);
  EXPECT_EQ(drawn.channels(), 3);
}

// One stderr line naming the file, non-zero exit.
void ExpectCleanError(const CommandResult& r, const std::string& file, const std::string& what) {
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(CountLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
}

TEST(DetectCli, UndecodableFile) {
  const auto dir = ScratchDir();
  std::ofstream(dir / "junk.png") << "this is not a PNG file at all";
  ExpectCleanError(RunFsp("detect " + (dir / "junk.png").string()), "junk.png", "does not decode");
}

TEST(DetectCli, EmptyFile) {
  const auto dir = ScratchDir();
  std::ofstream(dir / "empty.png").flush();
  ExpectCleanError(RunFsp("detect " + (dir / "empty.png").string()), "empty.png", "empty");
}

TEST(DetectCli, SixteenBitImage) {
  const auto dir = ScratchDir();
  cv::Mat img(48, 64, CV_16UC1, cv::Scalar(30000));
  ASSERT_TRUE(cv::imwrite((dir / "deep.png").string(), img));
  ExpectCleanError(RunFsp("detect " + (dir / "deep.png").string()), "deep.png", "8-bit");
}

TEST(DetectCli, MissingFileAndUnknownFamily) {
  const auto dir = ScratchDir();
  ExpectCleanError(RunFsp("detect " + (dir / "nope.png").string()), "nope.png", "does not exist");
  cv::imwrite((dir / "ok.png").string(), MakeSyntheticFrame(1).image);
  const auto r = RunFsp("detect --frontend apriltag --family tag99 " + (dir / "ok.png").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("tag99"), std::string::npos) << r.err;
}

TEST(DetectCli, CalibrationOfAnotherImageSize) {
  FSP_REQUIRE_TEST_DATA(calib, "euroc_v101_micro/inflight_frames_kimera_lcd/sensorLeft.yaml");
  const auto dir = ScratchDir();
  cv::imwrite((dir / "small.png").string(),
              MakeSyntheticFrame(1).image);  // 640x480, calib is 752x480
  ExpectCleanError(RunFsp("detect --calib " + calib + " " + (dir / "small.png").string()),
                   "small.png", "752x480");
}

TEST(DetectCli, WithCalibrationOnARealFrame) {
  FSP_REQUIRE_TEST_DATA(dir, "euroc_v101_micro/inflight_frames_kimera_lcd");
  const auto out = ScratchDir();
  const auto r = RunFsp("detect --calib " + dir + "/sensorLeft.yaml " + dir +
                        "/left_img_2.png --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("1 rectangles"), std::string::npos) << r.out;  // the board (see RealPhotos)
  EXPECT_TRUE(std::filesystem::exists(out / "left_img_2_detect.png"));
}

}  // namespace
}  // namespace fsp::test
