// Bad input: every problem gives one clear line naming the file (and line) and a non-zero exit,
// both from the library (InputError) and through `fsp info`. Fixtures are small files in a scratch
// dir.
#include <limits>

#include <gtest/gtest.h>

#include "dataset_fixtures.h"
#include "fsp/common/calibration.h"
#include "fsp/common/dataset.h"
#include "fsp/common/observations_io.h"
#include "test_util.h"

namespace fsp {
namespace {

namespace fs = std::filesystem;
using test::ErrorOf;

// A valid EuRoC layout in the scratch dir, broken by each test. Line numbers: data.csv line k+2 is
// frame k; imu0/data.csv line 1 is the header, line i+2 sample i.
class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::ScratchDir();
    t_ = test::MakeEuroc(dir_);
    mav0_ = dir_ / "mav0";
  }

  std::string Path(const std::string& rel) const { return (mav0_ / rel).string(); }

  // Replaces line LINE (1-based) of REL with TEXT.
  void ReplaceLine(const std::string& rel, int line, const std::string& text) const {
    const std::string all = test::ReadText(mav0_ / rel);
    std::string out;
    size_t start = 0;
    for (int i = 1; start < all.size(); ++i) {
      const size_t end = all.find('\n', start);
      out += (i == line ? text : all.substr(start, end - start)) + "\n";
      start = end + 1;
    }
    test::WriteText(mav0_ / rel, out);
  }

  std::string LibraryError() const {
    SourceOptions opts;
    opts.input = dir_.string();
    return ErrorOf([&] { OpenSource(opts); });
  }

  // `fsp info ARGS` fails cleanly: non-zero exit (not a signal), exactly one line on stderr
  // starting with "fsp: error: " and containing every string of MUST.
  static void ExpectCliError(const std::string& args, const std::vector<std::string>& must) {
    const test::CommandResult r = test::RunFsp("info " + args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_LT(r.exit_code, 128) << "crashed: " << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.rfind("fsp: error: ", 0), 0u) << r.err;
    EXPECT_EQ(r.err.back(), '\n');
    for (const std::string& m : must)
      EXPECT_NE(r.err.find(m), std::string::npos) << "'" << m << "' not in: " << r.err;
  }

  void ExpectInfoError(const std::vector<std::string>& must) const {
    ExpectCliError("'" + dir_.string() + "'", must);
  }

  fs::path dir_, mav0_;
  std::vector<int64_t> t_;
};

TEST_F(BadInput, FixtureIsValid) {
  SourceOptions opts;
  opts.input = dir_.string();
  EXPECT_EQ(OpenSource(opts)->frame_times().size(), 4u);
  const auto r = test::RunFsp("info '" + dir_.string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
}

TEST_F(BadInput, MissingFolder) {
  const std::string missing = (dir_ / "no_such_dir").string();
  SourceOptions opts;
  opts.input = missing;
  EXPECT_EQ(ErrorOf([&] { OpenSource(opts); }), missing + ": input not found");
  ExpectCliError("'" + missing + "'", {missing + ": input not found"});
}

TEST_F(BadInput, MissingImageNamedInDataCsv) {
  fs::remove(mav0_ / "cam0" / "data" / (std::to_string(t_[2]) + ".png"));
  const std::string want =
      Path("cam0/data.csv") + ":4: image '" + std::to_string(t_[2]) + ".png' not found";
  EXPECT_NE(LibraryError().find(want), std::string::npos) << LibraryError();
  ExpectInfoError({want});
}

TEST_F(BadInput, RowWithSixColumns) {
  ReplaceLine("imu0/data.csv", 5, std::to_string(t_[0]) + ",0.1,0.2,0.3,0.0,9.8");
  const std::string want = Path("imu0/data.csv") + ":5: expected 7 columns in IMU csv, found 6";
  EXPECT_EQ(LibraryError(), want);
  ExpectInfoError({want});
}

TEST_F(BadInput, NonNumericField) {
  ReplaceLine("imu0/data.csv", 7,
              std::to_string(t_[0] - 20'000'000 + 25'000'000) + ",0.1,zero,0.3,0.0,0.0,9.8");
  const std::string want = Path("imu0/data.csv") + ":7: column 3 (wy) is not a number: 'zero'";
  EXPECT_EQ(LibraryError(), want);
  ExpectInfoError({want});
  // In data.csv too.
  ReplaceLine("cam0/data.csv", 3, "12x45,img.png");
  EXPECT_NE(LibraryError().find(Path("cam0/data.csv") + ":3: column 1 (t_ns) is not an integer"),
            std::string::npos)
      << LibraryError();
}

TEST_F(BadInput, NanInImu) {
  ReplaceLine("imu0/data.csv", 4,
              std::to_string(t_[0] - 20'000'000 + 10'000'000) + ",0.1,0.2,0.3,nan,0.0,9.8");
  const std::string want = Path("imu0/data.csv") + ":4: column 5 (ax) is not finite: 'nan'";
  EXPECT_EQ(LibraryError(), want);
  ExpectInfoError({want});
}

TEST_F(BadInput, TimestampsGoingBackwards) {
  // Frames 1 and 2 swapped in data.csv.
  ReplaceLine("cam0/data.csv", 3, std::to_string(t_[2]) + "," + std::to_string(t_[2]) + ".png");
  ReplaceLine("cam0/data.csv", 4, std::to_string(t_[1]) + "," + std::to_string(t_[1]) + ".png");
  const std::string want = Path("cam0/data.csv") + ":4: timestamp " + std::to_string(t_[1]) +
                           " goes backwards (line 3 has " + std::to_string(t_[2]) + ")";
  EXPECT_EQ(LibraryError(), want);
  ExpectInfoError({want});
}

TEST_F(BadInput, ImuTimestampsGoingBackwards) {
  // IMU sample on line 6 (sample 4) carries the time of sample 2.
  const int64_t t2 = t_[0] - 20'000'000 + 2 * 5'000'000, t3 = t2 + 5'000'000;
  ReplaceLine("imu0/data.csv", 6, std::to_string(t2) + ",0,0,0,0,0,9.81");
  const std::string want = Path("imu0/data.csv") + ":6: timestamp " + std::to_string(t2) +
                           " goes backwards (line 5 has " + std::to_string(t3) + ")";
  EXPECT_EQ(LibraryError(), want);
  ExpectInfoError({want});
}

TEST_F(BadInput, DuplicateTimestamp) {
  // IMU sample on line 6 repeats the time of line 5.
  const int64_t t5 = t_[0] - 20'000'000 + 3 * 5'000'000;
  ReplaceLine("imu0/data.csv", 6, std::to_string(t5) + ",0,0,0,0,0,9.81");
  const std::string want =
      Path("imu0/data.csv") + ":6: duplicate timestamp " + std::to_string(t5) + " (also on line 5)";
  EXPECT_EQ(LibraryError(), want);
  ExpectInfoError({want});
}

TEST_F(BadInput, EmptyFiles) {
  test::WriteText(mav0_ / "imu0" / "data.csv", "");
  EXPECT_EQ(LibraryError(),
            Path("imu0/data.csv") + ": no IMU samples (expected rows t_ns,wx,wy,wz,ax,ay,az)");
  ExpectInfoError({Path("imu0/data.csv") + ": no IMU samples"});

  test::WriteText(mav0_ / "cam0" / "data.csv", "#timestamp [ns],filename\n");
  EXPECT_EQ(LibraryError(),
            Path("cam0/data.csv") + ": no frames listed (expected rows t_ns,filename)");

  test::WriteText(mav0_ / "cam0" / "sensor.yaml", "");
  EXPECT_EQ(LibraryError(), Path("cam0/sensor.yaml") + ": calibration file is empty");
}

TEST_F(BadInput, ImageThatDoesNotDecode) {
  // A later frame: OpenSource only checks the first, `fsp info` decodes them all, --quick does not.
  const std::string bad = Path("cam0/data/" + std::to_string(t_[3]) + ".png");
  test::WriteText(bad, "this is not a PNG\n");
  SourceOptions opts;
  opts.input = dir_.string();
  auto src = OpenSource(opts);
  EXPECT_EQ(ErrorOf([&] { src->ReadFrame(3); }),
            bad + ": image does not decode (corrupt or not an image file)");
  ExpectInfoError({bad + ": image does not decode"});
  EXPECT_EQ(test::RunFsp("info --quick '" + dir_.string() + "'").exit_code, 0);
  // Next() throws the same when it reaches the frame.
  EXPECT_EQ(ErrorOf([&] {
              while (src->Next()) {
              }
            }),
            bad + ": image does not decode (corrupt or not an image file)");

  // A truncated PNG (as a crashed writer leaves it) as the first frame: libpng's own message is
  // quoted, not printed.
  const std::string first = Path("cam0/data/" + std::to_string(t_[0]) + ".png");
  const std::string bytes = test::ReadText(first);
  test::WriteText(first, bytes.substr(0, bytes.size() / 2));
  EXPECT_NE(LibraryError().find(first + ": image does not decode"), std::string::npos)
      << LibraryError();

  // An empty image file.
  test::WriteText(first, "");
  EXPECT_EQ(LibraryError(), first + ": image file is empty");
}

TEST_F(BadInput, CalibrationResolutionDiffersFromImages) {
  test::WriteText(mav0_ / "cam0" / "sensor.yaml", test::EurocCamYaml(64, 48));
  const std::string first = Path("cam0/data/" + std::to_string(t_[0]) + ".png");
  const std::string want = first + ": image size 32x24 differs from the calibration's 64x48 (" +
                           Path("cam0/sensor.yaml") + ")";
  EXPECT_EQ(LibraryError(), want);
  ExpectInfoError({want});

  // A later image of another size, with a matching calibration: caught when decoded.
  test::WriteText(mav0_ / "cam0" / "sensor.yaml", test::EurocCamYaml());
  const std::string later = Path("cam0/data/" + std::to_string(t_[2]) + ".png");
  cv::imwrite(later, test::TestImage(2, 40, 24));
  SourceOptions opts;
  opts.input = dir_.string();
  auto src = OpenSource(opts);
  EXPECT_EQ(ErrorOf([&] {
              src->ReadFrame(2);
            }).rfind(later + ": image size 40x24 differs from the calibration's 32x24", 0),
            0u);
}

TEST_F(BadInput, UnsupportedCameraModel) {
  std::string yaml = test::EurocCamYaml();
  yaml.replace(yaml.find("radial-tangential"), 17, "equidistant");
  test::WriteText(mav0_ / "cam0" / "sensor.yaml", yaml);
  const std::string want =
      Path("cam0/sensor.yaml") + ":11: unsupported camera model 'pinhole' with 'equidistant'";
  EXPECT_EQ(LibraryError().rfind(want, 0), 0u) << LibraryError();
  ExpectInfoError({want});
}

TEST_F(BadInput, VideoAndFolderInputs) {
  const std::string calib = (dir_ / "calib.yaml").string(), imu = (dir_ / "imu.csv").string();
  WriteCalibration(test::TestCalibration(), calib);
  WriteImuCsv(test::TestImu(0, 1'000'000'000), imu);
  const auto open = [&](const std::string& input, const std::string& c, const std::string& i) {
    SourceOptions opts;
    opts.input = input;
    opts.calib = c;
    opts.imu = i;
    return ErrorOf([&] { OpenSource(opts); });
  };

  // Not a video: FFmpeg's complaint is quoted in the one line, not printed on its own.
  const std::string junk = (dir_ / "junk.mp4").string();
  test::WriteText(junk, "definitely not an mp4 file\n");
  ExpectCliError("'" + junk + "' --calib '" + calib + "' --imu '" + imu + "'",
                 {junk + ": cannot open as a video"});

  // A video or image folder without --calib/--imu.
  EXPECT_EQ(open(junk, "", imu), junk + ": a video needs --calib FILE and --imu FILE");
  const auto folder = dir_ / "images";
  fs::create_directories(folder);
  cv::imwrite((folder / "frame.png").string(), test::TestImage(0));
  EXPECT_EQ(open(folder.string(), calib, "").rfind(folder.string() + ": an image folder", 0), 0u);

  // An image whose name is not a timestamp, and two images with the same timestamp.
  EXPECT_EQ(open(folder.string(), calib, imu)
                .rfind((folder / "frame.png").string() +
                           ": image file name is not a nanosecond timestamp",
                       0),
            0u);
  fs::remove(folder / "frame.png");
  cv::imwrite((folder / "100000000.png").string(), test::TestImage(0));
  cv::imwrite((folder / "100000000.jpg").string(), test::TestImage(0));
  EXPECT_EQ(open(folder.string(), calib, imu)
                .rfind(folder.string() + ": duplicate timestamp 100000000", 0),
            0u);

  // IMU and frames on different clocks.
  fs::remove(folder / "100000000.jpg");
  WriteImuCsv(test::TestImu(5'000'000'000, 6'000'000'000), imu);
  ExpectCliError("'" + folder.string() + "' --calib '" + calib + "' --imu '" + imu + "'",
                 {imu + ": IMU samples span", "no overlap in time"});

  // A missing --imu file.
  EXPECT_EQ(open(folder.string(), calib, imu + ".missing"), imu + ".missing: IMU csv not found");
}

// A time offset that moves the frame times out of int64 nanoseconds (undefined behaviour when it
// was added), and frames and IMU samples spanning more than 292 years (Summarize's differences
// overflowed): clear errors.
TEST_F(BadInput, TimeOffsetBeyondInt64) {
  test::WriteText(mav0_ / "cam0" / "sensor.yaml",
                  "camera: {width: 32, height: 24, fx: 30, fy: 30, cx: 16, cy: 12}\n"
                  "T_B_C: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n"
                  "time_offset_ns: 9223372036000000000\n");
  const std::string what = LibraryError();
  EXPECT_NE(what.find("sensor.yaml: time_offset_ns 9223372036000000000 moves the frame times"),
            std::string::npos)
      << what;
  EXPECT_NE(what.find("out of the range of int64 nanoseconds"), std::string::npos) << what;
}

TEST_F(BadInput, TimesSpanMoreThanInt64) {
  test::WriteText(mav0_ / "imu0" / "data.csv",
                  "-9000000000000000000,0,0,0,0,0,9.81\n9000000000000000000,0,0,0,0,0,9.81\n");
  const std::string what = LibraryError();
  EXPECT_NE(what.find("imu0/data.csv: the frames (the first "), std::string::npos) << what;
  EXPECT_NE(what.find("more than 292 years"), std::string::npos) << what;
}

// Findings of the fuzz targets (fuzz/README.md), each with its minimal input, and what reading
// the readers beside them showed.

// fuzz_corners_csv: a corner of 4e70 px was read, but written back cut to 63 characters (the
// writer's fixed buffer): the file read back held another number.
TEST(FuzzFindings, CornerRowsWithHugeCoordinateRoundTrip) {
  const fs::path dir = test::ScratchDir();
  test::WriteText(dir / "corners.csv", "0,2,10,4e70,30,20,30,5,10,5\n");
  const std::vector<CornerRow> rows = ReadCornerRows((dir / "corners.csv").string());
  ASSERT_EQ(rows.size(), 1u);
  WriteCornerRows(rows, (dir / "written.csv").string(), true);
  const std::vector<CornerRow> back = ReadCornerRows((dir / "written.csv").string());
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].corners[0].y(), 4e70);
}

// An object id beyond int was wrapped silently (4294967297 read as 1).
TEST(FuzzFindings, CornerRowObjectIdOutOfRange) {
  const fs::path dir = test::ScratchDir();
  test::WriteText(dir / "corners.csv", "0,1,1,1,2,1,2,2,1,2\n0,4294967297,1,1,2,1,2,2,1,2\n");
  const std::string what = ErrorOf([&] { ReadCornerRows((dir / "corners.csv").string()); });
  EXPECT_NE(what.find("corners.csv:2: column 2 (object_id) is out of range"), std::string::npos)
      << what;
}

// fsp calib.yaml: a time_offset_ns of 1e30 was converted to int64 (undefined behaviour) and one
// beyond 2^53 was rounded through a double; now every int64 reads exactly and the rest is an error.
TEST(FuzzFindings, CalibTimeOffsetOutOfRange) {
  const fs::path dir = test::ScratchDir();
  const std::string head =
      "camera: {width: 32, height: 24, fx: 30, fy: 30, cx: 16, cy: 12}\n"
      "T_B_C: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n";
  const std::string path = (dir / "calib.yaml").string();
  test::WriteText(path, head + "time_offset_ns: 1e30\n");
  EXPECT_NE(ErrorOf([&] {
              ReadCalibration(path);
            }).find("calib.yaml:3: 'time_offset_ns' is out of range (int64 nanoseconds): '1e30'"),
            std::string::npos);
  test::WriteText(path, head + "time_offset_ns: 9223372036854775808\n");
  EXPECT_NE(ErrorOf([&] { ReadCalibration(path); }).find("out of range"), std::string::npos);
  test::WriteText(path, head + "time_offset_ns: 9007199254740993\n");
  EXPECT_EQ(ReadCalibration(path).time_offset_ns, 9007199254740993);
  test::WriteText(path, head + "time_offset_ns: -9223372036854775808\n");
  EXPECT_EQ(ReadCalibration(path).time_offset_ns, std::numeric_limits<int64_t>::min());
  test::WriteText(path, head + "time_offset_ns: -1.5e9\n");
  EXPECT_EQ(ReadCalibration(path).time_offset_ns, -1'500'000'000);
}

// Kalibr: timeshift_cam_imu: 1e300 gave llround's unspecified result (INT64_MIN) silently.
TEST(FuzzFindings, KalibrTimeshiftOutOfRange) {
  const fs::path dir = test::ScratchDir();
  const std::string path = (dir / "camchain.yaml").string();
  test::WriteText(path,
                  "cam0:\n  T_imu_cam: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n"
                  "  intrinsics: [30, 30, 16, 12]\n  resolution: [32, 24]\n"
                  "  timeshift_cam_imu: 1e300\n");
  EXPECT_NE(ErrorOf([&] {
              ReadCalibration(path);
            }).find("camchain.yaml:5: 'timeshift_cam_imu' is out of range"),
            std::string::npos);
}

// Kalibr T_cam_imu with a translation near the largest double: its inverse overflowed to inf and
// ReadCameraExtrinsics returned it.
TEST(FuzzFindings, KalibrExtrinsicsTooLargeToInvert) {
  const fs::path dir = test::ScratchDir();
  const std::string path = (dir / "camchain.yaml").string();
  test::WriteText(path,
                  "cam0:\n  T_cam_imu: [0, -1, 0, 1.5e308, 1, 0, 0, 1.5e308, 0, 0, 1, 0, 0, 0, 0, "
                  "1]\n  camera_model: omni\n");
  EXPECT_NE(ErrorOf([&] {
              ReadCameraExtrinsics(path);
            }).find("camchain.yaml:2: 'T_cam_imu' has a translation too large to invert"),
            std::string::npos);
}

}  // namespace
}  // namespace fsp
