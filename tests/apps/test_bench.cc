// `fsp bench`: the suite file, the process pool, the whole machinery on a tiny suite (a 4 s scene,
// two configurations, two parallel jobs) and the plotting script on a small hand-made JSON.
#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "bench_jobs.h"
#include "bench_suite.h"
#include "common/dataset_fixtures.h"
#include "fsp/common/error.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

const std::string kPython = "/usr/bin/python3";  // Debian's, with python3-matplotlib
const std::string kPlotScript = std::string(FSP_SOURCE_DIR) + "/scripts/bench_plots.py";

bool HaveMatplotlib() {
  return std::system((kPython + " -c 'import matplotlib' >/dev/null 2>&1").c_str()) == 0;
}

// A python that behaves as if python3-matplotlib were not installed: a shell wrapper that puts a
// `matplotlib` package raising ImportError first on the path.
std::string PythonWithoutMatplotlib(const fs::path& dir) {
  test::WriteText(dir / "shim" / "matplotlib" / "__init__.py", "raise ImportError('hidden')\n");
  const fs::path wrapper = dir / "python_no_mpl";
  test::WriteText(wrapper, "#!/bin/sh\nPYTHONPATH=" + (dir / "shim").string() + " exec " + kPython +
                               " \"$@\"\n");
  ::chmod(wrapper.c_str(), 0755);
  return wrapper.string();
}

Json ReadJson(const fs::path& p) {
  return Json::parse(test::Slurp(p));
}

TEST(BenchSuite, RepositorySuite) {
  const std::string path = std::string(FSP_SOURCE_DIR) + "/assets/bench/suite.yaml";
  for (bool quick : {true, false}) {
    const BenchSuite suite = ReadBenchSuite(path, quick);
    ASSERT_GE(suite.scenes.size(), 3u) << "quick " << quick;
    EXPECT_EQ(suite.scenes[0].name, "default_room");  // the gate's default scene
    bool hall = false;
    for (const BenchScene& s : suite.scenes) {
      // A scene is a scene file, or the C-SLAM logs in the data folder (converted by the bench).
      EXPECT_TRUE(s.cslam_logs.empty() ? fs::exists(s.scene) : s.scene.empty()) << s.name;
      EXPECT_FALSE(s.seeds.empty());
      EXPECT_FALSE(s.why.empty()) << s.name;
      if (s.name != "hall_flight") continue;
      hall = true;
      for (const BenchConfig& c : s.configs)  // batch on the 135 s flight takes > 12 min
        EXPECT_EQ(c.mode, backend::EstimatorMode::kWindow) << c.name;
    }
    EXPECT_TRUE(hall);
  }
}

TEST(BenchSuite, ConfigNames) {
  BenchConfig c;
  std::string why;
  ASSERT_TRUE(ParseBenchConfig("fsp-window", &c, &why));
  EXPECT_EQ(c.name, "gt-corners/fsp-window");
  ASSERT_TRUE(ParseBenchConfig("rect/fhp-batch", &c, &why));
  EXPECT_EQ(c.frontend, "rect");
  EXPECT_EQ(c.landmarks, backend::LandmarkType::kFhp);
  EXPECT_EQ(c.mode, backend::EstimatorMode::kBatch);
  EXPECT_FALSE(c.pixel_sigma);
  // gt-corners with its own noise: the name keeps it, the front end is gt-corners.
  ASSERT_TRUE(ParseBenchConfig("gt-corners-0px/fsp-batch", &c, &why)) << why;
  EXPECT_EQ(c.name, "gt-corners-0px/fsp-batch");
  EXPECT_EQ(c.frontend, "gt-corners");
  ASSERT_TRUE(c.pixel_sigma);
  EXPECT_EQ(*c.pixel_sigma, 0.0);
  ASSERT_TRUE(ParseBenchConfig("gt-corners-2.5px/fhp-window", &c, &why)) << why;
  EXPECT_EQ(*c.pixel_sigma, 2.5);
  for (const char* bad : {"gt-corners-px/fsp-window", "gt-corners--1px/fsp-window",
                          "gt-corners-1e3px/fsp-window", "gt-corners-1/fsp-window"})
    EXPECT_FALSE(ParseBenchConfig(bad, &c, &why)) << bad;
  EXPECT_FALSE(ParseBenchConfig("corners/fsp-window", &c, &why));
  EXPECT_FALSE(ParseBenchConfig("fsp", &c, &why));
  EXPECT_NE(why.find("'fsp' is not FRONTEND/LANDMARKS-MODE"), std::string::npos) << why;
}

TEST(BenchSuite, BadFilesNameTheLine) {
  const fs::path dir = test::ScratchDir();
  const auto error = [&](const std::string& text) {
    test::WriteText(dir / "s.yaml", text);
    return test::ErrorOf([&] { ReadBenchSuite((dir / "s.yaml").string(), true); });
  };
  const std::string head = "scenes:\n  - name: a\n    scene: a.yaml\n";
  std::string e = error(head + "    quick: {duration_s: 4, seeds: [1], configs: [fsp-walk]}\n");
  EXPECT_NE(e.find("s.yaml:4: configs: 'fsp-walk'"), std::string::npos) << e;
  e = error(head + "    quick: {duration_s: 4, seeds: [1, 1], configs: [fsp-window]}\n");
  EXPECT_NE(e.find("s.yaml:4: seeds: seed 1 repeated"), std::string::npos) << e;
  e = error(head + "    quick: {duration_s: -4, seeds: [1], configs: [fsp-window]}\n");
  EXPECT_NE(e.find("duration_s: must be a positive number"), std::string::npos) << e;
  e = error(head + "    quick: {seeds: [1], configs: [fsp-window]}\n");
  EXPECT_NE(e.find("a part needs duration_s, seeds and configs"), std::string::npos) << e;
  e = error(head + "    slow: {}\n");
  EXPECT_NE(e.find("s.yaml:4: unknown key 'slow'"), std::string::npos) << e;
  e = error(head + "    full: {duration_s: 4, seeds: [1], configs: [fsp-window]}\n");
  EXPECT_NE(e.find("no scene has a \"quick\" part"), std::string::npos) << e;
  e = error(head +
            "    quick: {duration_s: 4, seeds: [1], configs: [{config: fsp-window, "
            "seeds: [2]}]}\n");
  EXPECT_NE(e.find("s.yaml:4: configs: gt-corners/fsp-window: seed 2 is not one of the scene's"),
            std::string::npos)
      << e;
  // The scene file is resolved against the suite file's folder; a configuration's own seeds.
  test::WriteText(dir / "s.yaml",
                  head +
                      "    quick: {duration_s: 4, seeds: [3, 1], configs: [fsp-window, "
                      "{config: rect/fsp-batch, seeds: [1]}]}\n");
  const BenchSuite s = ReadBenchSuite((dir / "s.yaml").string(), true);
  EXPECT_EQ(s.scenes[0].scene, (dir / "a.yaml").string());
  EXPECT_EQ(s.scenes[0].seeds, (std::vector<unsigned>{3, 1}));
  ASSERT_EQ(s.scenes[0].configs.size(), 2u);
  EXPECT_EQ(s.scenes[0].configs[0].seeds, (std::vector<unsigned>{3, 1}));
  EXPECT_EQ(s.scenes[0].configs[1].name, "rect/fsp-batch");
  EXPECT_EQ(s.scenes[0].configs[1].seeds, (std::vector<unsigned>{1}));

  // The C-SLAM logs instead of a scene file, and a published reference.
  const std::string logs =
      "scenes:\n  - name: p\n    cslam_logs: cslam_paper_flight\n"
      "    quick: {duration_s: 4, seeds: [1], configs: [gt-corners-0px/fsp-batch]}\n";
  test::WriteText(dir / "s.yaml",
                  logs + "    reference: {label: the paper, rpe_trans_m: 0.0155}\n");
  const BenchSuite p = ReadBenchSuite((dir / "s.yaml").string(), true);
  EXPECT_EQ(p.scenes[0].cslam_logs, "cslam_paper_flight");
  EXPECT_TRUE(p.scenes[0].scene.empty());
  EXPECT_EQ(p.scenes[0].reference_label, "the paper");
  ASSERT_EQ(p.scenes[0].reference.size(), 1u);
  EXPECT_EQ(p.scenes[0].reference[0].first, "rpe_trans_m");
  EXPECT_EQ(p.scenes[0].reference[0].second, 0.0155);
  e = error(logs + "    reference: {rpe_trans_m: 0.0155}\n");
  EXPECT_NE(e.find("reference: needs a label"), std::string::npos) << e;
  e = error(logs + "    reference: {label: x, rpe_trans_m: fast}\n");
  EXPECT_NE(e.find("s.yaml:5: reference: rpe_trans_m: expected a number"), std::string::npos) << e;
  e = error(logs + "    scene: a.yaml\n");
  EXPECT_NE(e.find("needs either a scene file or cslam_logs"), std::string::npos) << e;
}

TEST(BenchJobs, ParallelWithDependencies) {
  const fs::path dir = test::ScratchDir();
  const std::string trace = (dir / "trace").string();
  const auto sh = [&](const std::string& script, int after = -1) {
    Job j;
    j.argv = {"/bin/sh", "-c", script};
    j.log = (dir / ("log" + std::to_string(after + 10))).string();
    j.after = after;
    return j;
  };
  std::vector<Job> jobs = {
      sh("echo start >> " + trace + "; sleep 1; echo end >> " + trace),
      sh("echo start >> " + trace + "; sleep 1; echo end >> " + trace + "; echo bye; exit 4"),
      sh("echo never >> " + trace, 1),  // after a failed job: not started
      sh("echo child >> " + trace, 0)};
  jobs[1].log = (dir / "second.log").string();
  std::vector<size_t> order;
  const std::vector<JobResult> r =
      RunJobs(jobs, 2, [&](size_t i, const JobResult&) { order.push_back(i); });
  ASSERT_EQ(r.size(), 4u);
  EXPECT_TRUE(r[0].ok());
  EXPECT_EQ(r[1].exit_code, 4);
  EXPECT_FALSE(r[2].started);
  EXPECT_TRUE(r[3].ok());
  EXPECT_EQ(order.size(), 4u);
  EXPECT_EQ(LastLine((dir / "second.log").string()), "bye");
  // Two at a time: both started before either ended; the dependent job ran after its parent.
  const std::string t = test::Slurp(trace);
  EXPECT_EQ(t.substr(0, 12), "start\nstart\n") << t;
  EXPECT_EQ(t.find("never"), std::string::npos) << t;
  EXPECT_NE(t.find("child"), std::string::npos) << t;
  // A program that cannot be started is a failed job, with the reason in its log.
  Job nope;
  nope.argv = {(dir / "no_such_program").string()};
  nope.log = (dir / "nope.log").string();
  EXPECT_FALSE(RunJobs({nope}, 1)[0].ok());
}

// The whole machinery on a tiny suite: a 4 s default room, gt-corners FSP and FHP windows, two
// parallel jobs; then the same configurations on the rendered sequence (--sequence) with a gate
// that fails and a python without matplotlib.
TEST(Bench, TinySuiteEndToEnd) {
  const fs::path dir = test::ScratchDir();
  test::WriteText(dir / "suite.yaml",
                  "scenes:\n  - name: tiny\n    scene: " + std::string(FSP_SOURCE_DIR) +
                      "/assets/scenes/default_room.yaml\n    why: a test\n"
                      "    quick: {duration_s: 4, seeds: [1], configs: [fsp-window, fhp-window]}\n"
                      "  - name: paper\n    cslam_logs: cslam_paper_flight\n    why: a test\n"
                      "    quick: {duration_s: 4, seeds: [1], configs: [fsp-window]}\n");
  test::WriteText(dir / "pass.yaml",
                  "checks:\n  - {scene: tiny, config: fsp-window, metric: ate_se3_m, max: 1.0}\n"
                  "  - {config: fsp-batch, metric: ate_se3_m, max: 0.01}\n");  // not run: skipped
  const fs::path out = dir / "out";
  const test::CommandResult r =
      test::RunFsp("bench --quick --suite " + (dir / "suite.yaml").string() + " --thresholds " +
                   (dir / "pass.yaml").string() + " --out " + out.string() + " --jobs 2" +
                   " --data " + (dir / "no_data").string());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;

  const Json m = ReadJson(out / "metrics.json");
  EXPECT_EQ(m["meta"]["jobs"], 2);
  const Json& fsp = m["scenes"]["tiny"]["configs"]["gt-corners/fsp-window"];
  EXPECT_EQ(fsp["runs_ok"], 1);
  const Json& run = fsp["runs"]["1"];
  ASSERT_TRUE(run.contains("ate_se3_m")) << run.dump();
  EXPECT_LT(run["ate_se3_m"].get<double>(), 0.2);
  for (const char* key :
       {"scale_err", "ate_causal_se3_m", "rpe_trans_m", "objects_matched", "backend_ms_median",
        "realtime_factor", "corner_err_mean_m", "width_err_max_m"})
    EXPECT_TRUE(run.contains(key)) << key;
  EXPECT_EQ(fsp["aggregate"]["mean"]["ate_se3_m"], run["ate_se3_m"]);  // one seed
  // FSP reports its scale σ, the error in σ units and the variance factor; FHP has no σ.
  for (const char* key : {"scale_sigma", "scale_err_sigmas", "variance_factor"})
    EXPECT_TRUE(run.contains(key)) << key;
  EXPECT_FALSE(
      m["scenes"]["tiny"]["configs"]["gt-corners/fhp-window"]["runs"]["1"].contains("scale_sigma"));
  // The scene whose C-SLAM logs are not in the data folder: left out, saying why.
  ASSERT_TRUE(m["scenes_skipped"].contains("paper")) << m["scenes_skipped"].dump();
  EXPECT_NE(m["scenes_skipped"]["paper"].get<std::string>().find("LandmarksGT.log not found"),
            std::string::npos);
  EXPECT_TRUE(m["gate"]["pass"].get<bool>());
  EXPECT_TRUE(m["gate"]["checks"][1]["skipped"].get<bool>());
  // The series the plots read: per step and per corner.
  const Json series = ReadJson(out / run["series"].get<std::string>());
  EXPECT_EQ(series["rpe_trans_m"].size() + 1, series["t_s"].size());
  EXPECT_EQ(series["xy_est"].size(), series["t_s"].size());
  ASSERT_FALSE(series["per_object"].empty());
  EXPECT_EQ(series["per_object"][0]["corner_err_m"].size(), 4u);
  EXPECT_TRUE(series["stage_ms"].contains("backend"));

  const std::string report = test::Slurp(out / "report.md");
  EXPECT_NE(report.find("## tiny"), std::string::npos) << report;
  EXPECT_NE(report.find("| gt-corners/fsp-window | 1/1 | "), std::string::npos) << report;
  EXPECT_NE(report.find("| gt-corners/fhp-window | 1/1 | "), std::string::npos) << report;
  EXPECT_NE(report.find("**pass**"), std::string::npos) << report;
  EXPECT_NE(report.find("## Scale error against its sigma"), std::string::npos) << report;
  EXPECT_NE(report.find("| tiny | gt-corners/fsp-window | 1 | "), std::string::npos) << report;
  EXPECT_NE(report.find("## Scenes not run\n\n- paper: "), std::string::npos) << report;
  if (HaveMatplotlib()) {
    for (const char* png :
         {"tiny_top_view", "tiny_rpe", "tiny_corners", "tiny_sizes", "tiny_timing"}) {
      EXPECT_TRUE(fs::exists(out / "plots" / (std::string(png) + ".png"))) << png;
      EXPECT_NE(report.find("](plots/" + std::string(png) + ".png)"), std::string::npos) << png;
    }
  } else {
    EXPECT_NE(report.find("python3-matplotlib is missing"), std::string::npos) << report;
  }

  // The rendered sequence again (--sequence), a gate that fails, and no matplotlib: exit 3, and
  // report.md and metrics.json are still written, with the one line about the plots.
  test::WriteText(dir / "fail.yaml",
                  "checks:\n  - {scene: tiny, config: fhp-window, metric: ate_se3_m, max: 1e-9}\n");
  const fs::path out2 = dir / "out2";
  const test::CommandResult r2 = test::RunFsp(
      "bench --quick --suite " + (dir / "suite.yaml").string() + " --thresholds " +
      (dir / "fail.yaml").string() + " --out " + out2.string() + " --sequence " +
      (out / "sequences" / "tiny_s1").string() + " --python " + PythonWithoutMatplotlib(dir));
  EXPECT_EQ(r2.exit_code, 3) << r2.out << r2.err;
  EXPECT_NE(r2.err.find("accuracy gate failed"), std::string::npos) << r2.err;
  const std::string report2 = test::Slurp(out2 / "report.md");
  EXPECT_NE(report2.find("**FAIL**"), std::string::npos) << report2;
  EXPECT_NE(report2.find("Plots: not made: bench_plots.py: python3-matplotlib is missing"),
            std::string::npos)
      << report2;
  EXPECT_FALSE(fs::exists(out2 / "sequences"));  // nothing rendered
  const Json m2 = ReadJson(out2 / "metrics.json");
  // The same sequence, noise seed and configuration: the same trajectory.
  EXPECT_EQ(m2["scenes"]["tiny"]["configs"]["gt-corners/fsp-window"]["runs"]["1"]["ate_se3_m"],
            run["ate_se3_m"]);
}

// The plotting script alone on a small hand-made metrics.json: two configurations (FSP and FHP,
// one seed each), four poses, one object.
TEST(BenchPlots, SmallJson) {
  const fs::path dir = test::ScratchDir();
  const auto series = [](double err) {
    Json s;
    s["t_s"] = {0.0, 0.1, 0.2, 0.3};
    s["ate_m"] = {err, err, err, err};
    s["rpe_trans_m"] = {err, 2 * err, err};
    s["rpe_rot_deg"] = {0.01, 0.02, 0.01};
    s["xy_ref"] = {{0, 0}, {1, 0}, {2, 0}, {3, 0}};
    s["xy_est"] = {{0, err}, {1, err}, {2, err}, {3, err}};
    const Json corners = {{0, 2, 0}, {1, 2, 0}, {1, 2, 1}, {0, 2, 1}};
    s["objects_gt"] = {{{"id", 7}, {"class", "door"}, {"corners_W", corners}}};
    s["objects_est"] = {{{"id", 7}, {"corners_W", corners}}};
    s["per_object"] = {{{"id", 7},
                        {"class", "door"},
                        {"est_id", 7},
                        {"corner_err_m", {err, err, 2 * err, err}},
                        {"width_err_m", err},
                        {"height_err_m", 2 * err}}};
    s["stage_ms"] = {{"frontend", {{"median", 0.01}, {"p90", 0.02}, {"count", 4}}},
                     {"backend", {{"median", 5.0}, {"p90", 9.0}, {"count", 4}}},
                     {"finish", 12.0}};
    return s;
  };
  Json m;
  for (const char* config : {"gt-corners/fsp-window", "gt-corners/fhp-window"}) {
    const std::string file = std::string("runs/") + (config[11] == 's' ? "fsp" : "fhp") + ".json";
    test::WriteText(dir / file, series(config[11] == 's' ? 0.01 : 0.02).dump());
    m["scenes"]["small"]["configs"][config] = {
        {"runs", {{"1", {{"series", file}}}}},
        {"aggregate", {{"mean", {{"realtime_factor", 5.0}}}}}};
  }
  test::WriteText(dir / "metrics.json", m.dump());
  const std::string cmd = " " + kPlotScript + " " + (dir / "metrics.json").string() + " " +
                          (dir / "plots").string() + " > " + (dir / "log").string() + " 2>&1";
  if (HaveMatplotlib()) {
    ASSERT_EQ(std::system((kPython + cmd).c_str()), 0) << test::Slurp(dir / "log");
    for (const char* png :
         {"small_top_view", "small_rpe", "small_corners", "small_sizes", "small_timing"})
      EXPECT_GT(fs::file_size(dir / "plots" / (std::string(png) + ".png")), 1000u) << png;
  }
  // Without matplotlib: one line, exit 3.
  const int status = std::system((PythonWithoutMatplotlib(dir) + cmd).c_str());
  EXPECT_EQ(WEXITSTATUS(status), 3);
  EXPECT_EQ(test::Slurp(dir / "log"),
            "bench_plots.py: python3-matplotlib is missing (Debian: apt-get install "
            "python3-matplotlib); no plots\n");
}

}  // namespace
}  // namespace fsp::apps
