// `fsp eval` end to end: a hand-made sequence folder and run folder give every metric block with
// the expected numbers; bad input gives a non-zero exit and one line on stderr.
#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fsp/common/trajectory_io.h"
#include "test_util.h"

namespace fsp {
namespace {

constexpr double kPi = 3.14159265358979323846;

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

nlohmann::json ReadJson(const std::filesystem::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

int CountLines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n' ? 1 : 0;
  return n;
}

// G maps the estimate's world into the ground truth's: p_gt = R p_est + t.
const Mat3 kR = RotFromRpy(0.1, -0.2, 0.9);
const Vec3 kT(2.0, -1.0, 0.5);

// Sequence folder: 40 ground-truth poses at 20 Hz on a rising helix (EuRoC csv), two objects, a few
// corner observations. Run folder: the same poses in another world (TUM), a map with a door 0.05 m
// off at every corner, observations, run.json.
void MakeSequenceAndRun(const std::filesystem::path& seq, const std::filesystem::path& run) {
  std::vector<StateSample> gt;
  std::vector<StampedPose> est;
  for (int i = 0; i < 40; ++i) {
    const double a = 0.1 * i;
    StateSample s;
    s.t_ns = 1'000'000'000 + int64_t{i} * 50'000'000;
    s.T_W_B = Rigid3(RotFromRpy(0.05 * std::sin(a), 0.02 * a, a + kPi / 2),
                     Vec3(3.0 * std::cos(a), 3.0 * std::sin(a), 1.0 + 0.05 * i));
    gt.push_back(s);
    StampedPose p;
    p.t_ns = s.t_ns + 2'000'000;  // 2 ms late: still associated
    p.T_W_B = Rigid3(kR.transpose() * s.T_W_B.R(), kR.transpose() * (s.T_W_B.translation() - kT));
    est.push_back(p);
  }
  std::filesystem::create_directories(seq / "mav0" / "state_groundtruth_estimate0");
  std::filesystem::create_directories(run);
  WriteEurocGroundTruth(gt, (seq / "mav0" / "state_groundtruth_estimate0" / "data.csv").string());
  WriteTum(est, (run / "trajectory.tum").string());

  WriteText(seq / "objects_gt.json", R"({"objects": [
    {"id": 1, "class": "door", "corners_W": [[0,0,0],[1,0,0],[1,0,2],[0,0,2]], "width": 1.0, "height": 2.0},
    {"id": 2, "class": "window", "corners_W": [[2,0,1],[3,0,1],[3,0,2],[2,0,2]], "width": 1.0, "height": 1.0}]})");
  std::ostringstream map;
  map.precision(17);
  map << R"({"objects": [{"id": 1, "class": "door", "width": 1.1, "height": 2.0, "corners_W": [)";
  const Vec3 corners[4] = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 0, 2), Vec3(0, 0, 2)};
  for (int j = 0; j < 4; ++j) {
    const Vec3 c = kR.transpose() * (corners[j] + Vec3(0.03, 0.0, 0.04) - kT);
    map << (j ? "," : "") << "[" << c.x() << "," << c.y() << "," << c.z() << "]";
  }
  map << "]}]}";
  WriteText(run / "map.json", map.str());

  WriteText(seq / "observations_gt.csv",
            "# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4,fully_visible\n"
            "1000000000,1,100,100,150,100,150,50,100,50,1\n"
            "1000000000,2,300,300,310,300,310,290,300,290,1\n"
            "1050000000,1,100,100,150,100,150,50,100,50,1\n"
            "1050000000,2,300,300,310,300,310,290,300,290,0\n");
  WriteText(run / "observations.csv",
            "# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4\n"
            "1000000000,4,100,101,150,101,150,51,100,51\n"
            "1050000000,5,100,100,150,100,150,50,100,50\n"
            "1050000000,6,400,400,450,400,450,350,400,350\n");
  WriteText(run / "run.json", R"({"frames": 40, "keyframes": 10, "objects": 1, "wall_s": 1.25,
                                  "realtime_factor": 1.6, "stage_ms": {}})");
}

TEST(CmdEval, SequenceAndRunFoldersGiveEveryBlock) {
  const auto dir = test::ScratchDir();
  MakeSequenceAndRun(dir / "seq", dir / "run");
  const auto out = dir / "metrics.json";
  const auto r = test::RunFsp("eval --gt " + (dir / "seq").string() + " --est " +
                              (dir / "run").string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("ATE rmse"), std::string::npos) << r.out;
  const nlohmann::json m = ReadJson(out);
  // The top-view picture is written beside metrics.json and is a real image.
  const cv::Mat picture = cv::imread((dir / "eval_top_view.png").string());
  EXPECT_FALSE(picture.empty()) << r.out;
  EXPECT_GE(picture.cols, 500);

  const auto& t = m.at("trajectory");
  EXPECT_EQ(t.at("pairs"), 40);
  EXPECT_EQ(t.at("align"), "se3");
  EXPECT_LT(t.at("ate_rmse_m").get<double>(), 1e-8);
  EXPECT_LT(t.at("ate_median_m").get<double>(), 1e-8);
  EXPECT_LT(t.at("rpe_trans_rmse_m").get<double>(), 1e-8);
  EXPECT_LT(t.at("rpe_rot_rmse_deg").get<double>(), 1e-6);
  EXPECT_FALSE(t.contains("scale"));

  // The door: every corner 0.05 m off (after undoing G), width 0.1 off, height exact.
  const auto& o = m.at("objects");
  EXPECT_EQ(o.at("gt"), 2);
  EXPECT_EQ(o.at("estimated"), 1);
  EXPECT_EQ(o.at("matched"), 1);
  EXPECT_NEAR(o.at("corner_err_mean_m").get<double>(), 0.05, 1e-8);
  EXPECT_NEAR(o.at("corner_err_median_m").get<double>(), 0.05, 1e-8);
  EXPECT_NEAR(o.at("width_err_mean_m").get<double>(), 0.1, 1e-8);
  EXPECT_NEAR(o.at("width_err_max_m").get<double>(), 0.1, 1e-8);
  EXPECT_NEAR(o.at("height_err_mean_m").get<double>(), 0.0, 1e-8);
  EXPECT_NEAR(o.at("height_err_max_m").get<double>(), 0.0, 1e-8);

  // Front end: 3 fully visible GT rows, object 1 found twice (1 px, then exact; ids 4 then 5: one
  // switch), object 2 missed; one of three detections is spurious.
  const auto& f = m.at("frontend");
  EXPECT_DOUBLE_EQ(f.at("recall").get<double>(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(f.at("precision").get<double>(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(f.at("corner_err_px_median").get<double>(), 0.5);
  EXPECT_EQ(f.at("id_switches"), 1);
  // Tracking: no cam0/data.csv, so the frames are the files' 2 times; ids 4 and 5 both stand for
  // object 1; both of its fully visible rows are within 2 px (1 px, exact); id 6 matches nothing
  // but maps to no object either; no absence, so no return.
  EXPECT_EQ(f.at("frames"), 2);
  EXPECT_EQ(f.at("id_map"), nlohmann::json({{"4", 1}, {"5", 1}}));
  EXPECT_EQ(f.at("success_frames"), 2);
  EXPECT_EQ(f.at("success_total"), 2);
  EXPECT_DOUBLE_EQ(f.at("success_rate").get<double>(), 1.0);
  EXPECT_EQ(f.at("boxes_out_of_view"), 0);
  EXPECT_EQ(f.at("unmatched_est_rows"), 1);
  EXPECT_EQ(f.at("returns"), 0);
  EXPECT_FALSE(f.contains("reid_rate"));
  EXPECT_DOUBLE_EQ(f.at("id_switches_per_1000").get<double>(), 500.0);
  // The objects' geometric matching: map object 1 is ground-truth object 1.
  ASSERT_EQ(o.at("matches").size(), 1u);
  EXPECT_EQ(o.at("matches")[0].at("est_id"), 1);
  EXPECT_EQ(o.at("matches")[0].at("gt_id"), 1);
  EXPECT_NEAR(o.at("matches")[0].at("corner_err_m").get<double>(), 0.05, 1e-8);
  EXPECT_EQ(o.at("corner_order_errors"), 0);

  const auto& rt = m.at("runtime");
  EXPECT_EQ(rt.at("frames"), 40);
  EXPECT_DOUBLE_EQ(rt.at("wall_s").get<double>(), 1.25);
  EXPECT_DOUBLE_EQ(rt.at("realtime_factor").get<double>(), 1.6);
}

// Replaces every occurrence of FROM in the file at PATH by TO.
void ReplaceInFile(const std::filesystem::path& path, const std::string& from,
                   const std::string& to) {
  std::ostringstream buffer;
  buffer << std::ifstream(path).rdbuf();
  std::string text = buffer.str();
  for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  WriteText(path, text);
}

TEST(CmdEval, RenumberedTrackerIdsGiveTheSameNumbers) {
  // A tracker's ids are its own: renumbering the map and the observations changes only the id maps.
  const auto dir = test::ScratchDir();
  MakeSequenceAndRun(dir / "seq", dir / "run");
  const auto same = test::RunFsp("eval --gt " + (dir / "seq").string() + " --est " +
                                 (dir / "run").string() + " --out " + (dir / "same.json").string());
  ASSERT_EQ(same.exit_code, 0) << same.err;
  ReplaceInFile(dir / "run" / "map.json", "\"id\": 1,", "\"id\": 17,");
  for (const char* id : {"4", "5", "6"}) {
    ReplaceInFile(dir / "run" / "observations.csv", "0," + std::string(id) + ",",
                  "0," + std::string(id) + "0,");
  }
  const auto renumbered =
      test::RunFsp("eval --gt " + (dir / "seq").string() + " --est " + (dir / "run").string() +
                   " --out " + (dir / "renumbered.json").string());
  ASSERT_EQ(renumbered.exit_code, 0) << renumbered.err;
  nlohmann::json a = ReadJson(dir / "same.json"), b = ReadJson(dir / "renumbered.json");
  EXPECT_EQ(b.at("objects").at("matches")[0].at("est_id"), 17);
  EXPECT_EQ(b.at("objects").at("per_object")[0].at("est_id"), 17);
  EXPECT_EQ(b.at("frontend").at("id_map"), nlohmann::json({{"40", 1}, {"50", 1}}));
  EXPECT_EQ(b.at("frontend").at("per_object")[0].at("est_ids"), nlohmann::json({40, 50}));
  for (nlohmann::json* m : {&a, &b}) {
    m->at("objects").erase("matches");
    m->at("objects").erase("per_object");
    m->at("frontend").erase("id_map");
    for (nlohmann::json& o : m->at("frontend").at("per_object")) o.erase("est_ids");
  }
  EXPECT_EQ(a.at("objects"), b.at("objects"));
  EXPECT_EQ(a.at("frontend"), b.at("frontend"));
}

TEST(CmdEval, FramesComeFromCam0DataCsv) {
  // With the sequence's cam0/data.csv the front end counts all 40 frames (the files have rows in
  // 2).
  const auto dir = test::ScratchDir();
  MakeSequenceAndRun(dir / "seq", dir / "run");
  std::string csv = "#timestamp [ns],filename\n";
  for (int i = 0; i < 40; ++i) {
    const std::string t = std::to_string(1'000'000'000 + int64_t{i} * 50'000'000);
    csv += t + "," + t + ".png\n";
  }
  WriteText(dir / "seq" / "mav0" / "cam0" / "data.csv", csv);
  const auto out = dir / "metrics.json";
  const auto r = test::RunFsp("eval --gt " + (dir / "seq").string() + " --est " +
                              (dir / "run").string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadJson(out).at("frontend").at("frames"), 40);
  WriteText(dir / "seq" / "mav0" / "cam0" / "data.csv", csv + "12x,12.png\n");
  const auto bad =
      test::RunFsp("eval --gt " + (dir / "seq").string() + " --est " + (dir / "run").string());
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("data.csv:42: expected t_ns,filename"), std::string::npos) << bad.err;
}

TEST(CmdEval, AbsentPartsGiveAbsentBlocks) {
  const auto dir = test::ScratchDir();
  MakeSequenceAndRun(dir / "seq", dir / "run");
  std::filesystem::remove(dir / "run" / "map.json");
  std::filesystem::remove(dir / "run" / "run.json");
  const auto out = dir / "metrics.json";
  const auto r = test::RunFsp("eval --gt " + (dir / "seq" / "mav0").string() + " --est " +
                              (dir / "run").string() + " --align sim3 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json m = ReadJson(out);
  EXPECT_TRUE(m.contains("trajectory"));
  EXPECT_TRUE(m.contains("frontend"));  // found beside mav0
  EXPECT_FALSE(m.contains("objects"));
  EXPECT_FALSE(m.contains("runtime"));
  EXPECT_NEAR(m.at("trajectory").at("scale").get<double>(), 1.0, 1e-9);
  EXPECT_LT(m.at("trajectory").at("scale_err").get<double>(), 1e-9);
}

TEST(CmdEval, TumFilesAndPosYaw) {
  const auto dir = test::ScratchDir();
  MakeSequenceAndRun(dir / "seq", dir / "run");
  // The ground truth as a plain EuRoC csv against itself converted to TUM: exact under any
  // alignment.
  const std::string gt =
      (dir / "seq" / "mav0" / "state_groundtruth_estimate0" / "data.csv").string();
  std::vector<StampedPose> poses;
  for (const StateSample& s : ReadEurocGroundTruth(gt)) poses.push_back({s.t_ns, s.T_W_B});
  WriteTum(poses, (dir / "gt.tum").string());
  const auto r =
      test::RunFsp("eval --gt " + gt + " --est " + (dir / "gt.tum").string() + " --align posyaw");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("40 pairs"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("posyaw"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ATE rmse 0.000000 m"), std::string::npos) << r.out;
}

TEST(CmdEval, BadInputIsOneLineOnStderr) {
  const auto dir = test::ScratchDir();
  MakeSequenceAndRun(dir / "seq", dir / "run");
  const std::string seq = (dir / "seq").string(), run = (dir / "run").string();
  struct Case {
    std::string args;
    std::string fragment;
  };
  WriteText(dir / "bad_row.tum", "1.0 0 0 0 0 0 0 1\n1.05 0 0 0 0 0 1\n");
  WriteText(dir / "backwards.tum", "1.05 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 0 1\n");
  WriteText(dir / "far.tum", "100 0 0 0 0 0 0 1\n100.05 1 0 0 0 0 0 1\n100.1 0 1 0 0 0 0 1\n");
  WriteText(dir / "two.tum", "1.0 0 0 0 0 0 0 1\n1.05 1 0 0 0 0 0 1\n");
  WriteText(dir / "empty_dir" / ".keep", "");
  WriteText(dir / "bad_map" / "map.json", "{\"objects\": [{\"id\": 1}]}");
  WriteText(dir / "bad_map" / "trajectory.tum", "");
  const Case cases[] = {
      {"eval --gt " + seq + " --est " + (dir / "missing.tum").string(),
       "missing.tum: estimate not found"},
      {"eval --gt " + (dir / "nope").string() + " --est " + run, "nope: ground truth not found"},
      {"eval --gt " + seq + " --est " + (dir / "bad_row.tum").string(),
       "bad_row.tum:2: expected 8 columns"},
      {"eval --gt " + seq + " --est " + (dir / "backwards.tum").string(),
       "backwards.tum:2: timestamp 1.0 goes backwards"},
      {"eval --gt " + seq + " --est " + (dir / "far.tum").string(), "do not overlap in time"},
      {"eval --gt " + seq + " --est " + (dir / "two.tum").string(), "only 2 pose pairs"},
      {"eval --gt " + seq + " --est " + (dir / "empty_dir").string(),
       "no run output in this folder"},
      {"eval --gt " + (dir / "empty_dir").string() + " --est " + run,
       "no ground truth in this folder"},
      {"eval --gt " + seq + " --est " + run + " --align yaw",
       "--align must be se3, posyaw or sim3"},
      {"eval --gt " + seq + " --est " + (dir / "bad_map").string(), "no poses"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args);
    const auto r = test::RunFsp(c.args);
    EXPECT_NE(r.exit_code, 0);
    EXPECT_EQ(CountLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(c.fragment), std::string::npos) << r.err;
  }
}

}  // namespace
}  // namespace fsp
