// TUM and EuRoC ground-truth readers/writers: exact time parsing, quaternion order, clear errors.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "fsp/common/error.h"
#include "fsp/common/trajectory_io.h"
#include "test_util.h"

namespace fsp {
namespace {

std::string WriteText(const std::string& name, const std::string& text) {
  const std::string path = (test::ScratchDir() / name).string();
  std::ofstream(path) << text;
  return path;
}

// Expects READ to throw InputError whose message contains every one of the given fragments.
template <typename F>
void ExpectInputError(F read, const std::vector<std::string>& fragments) {
  try {
    read();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const InputError& e) {
    for (const std::string& frag : fragments) {
      EXPECT_NE(std::string(e.what()).find(frag), std::string::npos)
          << "'" << e.what() << "' lacks '" << frag << "'";
    }
  }
}

TEST(ParseSecondsToNs, ExactDecimalAndExponentForms) {
  int64_t ns = 0;
  ASSERT_TRUE(ParseSecondsToNs("1311868164.363181", &ns));
  EXPECT_EQ(ns, 1311868164363181000);
  ASSERT_TRUE(ParseSecondsToNs("1.403715278862139940e+09", &ns));
  EXPECT_EQ(ns, 1403715278862139940);
  ASSERT_TRUE(ParseSecondsToNs("-0.5", &ns));
  EXPECT_EQ(ns, -500000000);
  ASSERT_TRUE(ParseSecondsToNs("12", &ns));
  EXPECT_EQ(ns, 12000000000);
  ASSERT_TRUE(ParseSecondsToNs("0.0000000015", &ns));  // 1.5 ns rounds half away from zero
  EXPECT_EQ(ns, 2);
  ASSERT_TRUE(ParseSecondsToNs("2.5E-3", &ns));
  EXPECT_EQ(ns, 2500000);
  EXPECT_FALSE(ParseSecondsToNs("abc", &ns));
  EXPECT_FALSE(ParseSecondsToNs("1.2.3", &ns));
  EXPECT_FALSE(ParseSecondsToNs("1e", &ns));
  EXPECT_FALSE(ParseSecondsToNs("1e12", &ns));  // beyond int64 nanoseconds
}

TEST(ReadTum, ReadsSpaceAndCommaRowsWithComments) {
  const std::string path = WriteText("a.tum",
                                     "# t x y z qx qy qz qw\n"
                                     "1.5 1 2 3 0 0 0 1\n"
                                     "\n"
                                     "2.000000001,4,5,6,0,0,0.70710678118,0.70710678118\n");
  std::vector<double> t_s;
  const auto poses = ReadTum(path, &t_s);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].t_ns, 1500000000);
  EXPECT_EQ(poses[1].t_ns, 2000000001);
  EXPECT_DOUBLE_EQ(t_s[1], 2.000000001);
  EXPECT_TRUE(poses[0].T_W_B.translation().isApprox(Vec3(1, 2, 3)));
  // 90 degrees about z: x maps to y.
  EXPECT_TRUE((poses[1].T_W_B.R() * Vec3::UnitX()).isApprox(Vec3::UnitY(), 1e-9));
}

TEST(ReadTum, RoundTripKeepsNanosecondsAndDigits) {
  std::vector<StampedPose> poses(2);
  poses[0].t_ns = 1403715278862139940;
  poses[0].T_W_B = Rigid3(Quat(0.5, -0.5, 0.5, 0.5), Vec3(1234.567890123, -0.000123456789, 3.0));
  poses[1].t_ns = 1403715278912139893;
  poses[1].T_W_B =
      Rigid3(Quat(Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized())), Vec3(1e-7, 2, -3));
  const std::string path = (test::ScratchDir() / "rt.tum").string();
  WriteTum(poses, path);
  const auto back = ReadTum(path);
  ASSERT_EQ(back.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back[i].t_ns, poses[i].t_ns);
    EXPECT_LT((back[i].T_W_B.translation() - poses[i].T_W_B.translation()).norm(), 1e-8);
    EXPECT_LT(back[i].T_W_B.rotation().angularDistance(poses[i].T_W_B.rotation()), 1e-10);
  }
}

TEST(ReadTum, BadRowsNameFileAndLine) {
  ExpectInputError([&] { ReadTum(WriteText("cols.tum", "1 2 3 4 0 0 0 1\n2 1 2 3 0 0 1\n")); },
                   {"cols.tum:2", "expected 8 columns", "found 7"});
  ExpectInputError([&] { ReadTum(WriteText("nan.tum", "1 0 0 0 0 0 0 1\n2 nan 0 0 0 0 0 1\n")); },
                   {"nan.tum:2", "not finite"});
  ExpectInputError([&] { ReadTum(WriteText("word.tum", "1 0 0 0 0 0 0 1\n2 zero 0 0 0 0 0 1\n")); },
                   {"word.tum:2", "not a number"});
  ExpectInputError(
      [&] { ReadTum(WriteText("back.tum", "#c\n2 0 0 0 0 0 0 1\n1.5 0 0 0 0 0 0 1\n")); },
      {"back.tum:3", "does not increase"});
  ExpectInputError([&] { ReadTum(WriteText("same.tum", "2 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n")); },
                   {"same.tum:2", "does not increase"});
  ExpectInputError([&] { ReadTum(WriteText("quat.tum", "1 0 0 0 0 0 0 1\n2 0 0 0 0.5 0 0 1\n")); },
                   {"quat.tum:2", "quaternion norm"});
  ExpectInputError([&] { ReadTum(WriteText("empty.tum", "# nothing\n")); },
                   {"empty.tum", "no poses"});
  ExpectInputError([&] { ReadTum((test::ScratchDir() / "missing.tum").string()); },
                   {"missing.tum", "not found"});
}

TEST(ReadTum, NonDecreasingOrderAcceptsRepeatedStampsOnly) {
  const std::string text = "1 0 0 0 0 0 0 1\n1.0 1 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n";
  ExpectInputError([&] { ReadTum(WriteText("rep.tum", text)); },
                   {"rep.tum:2", "does not increase"});
  const auto poses = ReadTum(WriteText("rep.tum", text), nullptr, TimeOrder::kNonDecreasing);
  ASSERT_EQ(poses.size(), 3u);
  EXPECT_EQ(poses[1].t_ns, poses[0].t_ns);
  ExpectInputError(
      [&] {
        ReadTum(WriteText("bk.tum", "2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n"), nullptr,
                TimeOrder::kNonDecreasing);
      },
      {"bk.tum:2", "goes backwards"});
  ExpectInputError(
      [&] {
        ReadEurocGroundTruth(WriteText("bk.csv", "5,0,0,0,1,0,0,0\n4,0,0,0,1,0,0,0\n"),
                             TimeOrder::kNonDecreasing);
      },
      {"bk.csv:2", "goes backwards"});
}

TEST(ReadEurocGroundTruth, ConvertsWxyzToEigenOrder) {
  const std::string path = WriteText("gt.csv",
                                     "#timestamp, p_RS_R_x [m], ...\n"
                                     "1403715524907143168,1,2,3,0.70710678118,0,0,0.70710678118\n"
                                     "1403715524912143104,1,2,3,1,0,0,0,0.1,0.2,0.3,1,2,3,4,5,6\n");
  const auto states = ReadEurocGroundTruth(path);
  ASSERT_EQ(states.size(), 2u);
  EXPECT_EQ(states[0].t_ns, 1403715524907143168);
  EXPECT_NEAR(states[0].T_W_B.rotation().w(), std::sqrt(0.5), 1e-9);
  EXPECT_NEAR(states[0].T_W_B.rotation().z(), std::sqrt(0.5), 1e-9);
  EXPECT_TRUE(states[0].v_W.isZero());
  EXPECT_TRUE(states[1].v_W.isApprox(Vec3(0.1, 0.2, 0.3)));
  EXPECT_TRUE(states[1].gyro_bias.isApprox(Vec3(1, 2, 3)));
  EXPECT_TRUE(states[1].acc_bias.isApprox(Vec3(4, 5, 6)));

  const std::string out = (test::ScratchDir() / "out.csv").string();
  WriteEurocGroundTruth(states, out);
  const auto back = ReadEurocGroundTruth(out);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[1].t_ns, states[1].t_ns);
  EXPECT_LT(back[0].T_W_B.rotation().angularDistance(states[0].T_W_B.rotation()), 1e-10);
  EXPECT_TRUE(back[1].acc_bias.isApprox(states[1].acc_bias));
}

TEST(ReadEurocGroundTruth, BadRowsNameFileAndLine) {
  ExpectInputError([&] { ReadEurocGroundTruth(WriteText("c.csv", "#h\n1,0,0,0,1,0,0,0,1\n")); },
                   {"c.csv:2", "8, 11, 14 or 17 columns", "found 9"});
  ExpectInputError(
      [&] { ReadEurocGroundTruth(WriteText("t.csv", "5,0,0,0,1,0,0,0\n4,0,0,0,1,0,0,0\n")); },
      {"t.csv:2", "does not increase"});
  ExpectInputError([&] { ReadEurocGroundTruth(WriteText("q.csv", "5,0,0,0,0,0,0,0\n")); },
                   {"q.csv:1", "quaternion norm"});
  ExpectInputError([&] { ReadEurocGroundTruth(WriteText("i.csv", "5.5,0,0,0,1,0,0,0\n")); },
                   {"i.csv:1", "not an integer"});
  ExpectInputError([&] { ReadEurocGroundTruth(WriteText("f.csv", "5,0,inf,0,1,0,0,0\n")); },
                   {"f.csv:1", "not finite"});
}

}  // namespace
}  // namespace fsp
