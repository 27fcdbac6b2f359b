// The gt-corners front end on a tiny hand-written sequence folder: exact corners at σ = 0, the same
// noise for the same seed, invisible rows dropped, clear errors. The corners front end (another
// detector's distorted corners): undistorted with the calibration, classes from an objects file,
// the time offset, and a clear error for every kind of bad file.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/dataset_fixtures.h"
#include "fsp/common/error.h"
#include "fsp/common/observations_io.h"
#include "gt_corners.h"
#include "test_util.h"

namespace fsp::apps {
namespace {

namespace fs = std::filesystem;
using test::ErrorOf;
using test::WriteText;

// Corners of object ID in frame K (distinct per object and frame).
Corners TrueCorners(int id, int k) {
  const double u0 = 5.0 + id + 0.25 * k, v0 = 18.0 - 0.5 * k;
  return {Vec2(u0, v0), Vec2(u0 + 10.5, v0), Vec2(u0 + 10.5, v0 - 8.25), Vec2(u0, v0 - 8.25)};
}

// A EuRoC folder with 4 frames, objects 1 (door) and 2 (tag) seen in every frame; object 2 shows
// one corner only in frame 2. Returns the frame times.
std::vector<int64_t> MakeSequence(const fs::path& dir) {
  const std::vector<int64_t> t = test::MakeEuroc(dir, 4);
  std::vector<CornerRow> rows;
  for (int k = 0; k < 4; ++k) {
    for (int id : {1, 2}) {
      CornerRow r;
      r.t_ns = t[k];
      r.object_id = id;
      r.corners = TrueCorners(id, k);
      if (id == 2 && k == 2) {  // one corner in view: too few to be handed out
        r.visible = {true, false, false, false};
      }
      rows.push_back(r);
    }
  }
  WriteCornerRows(rows, (dir / "observations_gt.csv").string(), /*with_flag=*/true);
  WriteText(dir / "objects_gt.json",
            R"({"objects": [{"id": 1, "class": "door", "width": 0.9, "height": 2.0},
                            {"id": 2, "class": "tag", "width": 0.16, "height": 0.16}]})");
  return t;
}

GtCornersOptions Sigma(double sigma, uint32_t seed = 1) {
  GtCornersOptions o;
  o.pixel_sigma = sigma;
  o.seed = seed;
  return o;
}

TEST(GtCorners, NoiseFreeGivesTheExactCornersAndClasses) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  GtCornersFrontend fe(dir.string(), Sigma(0.0));
  for (int k = 0; k < 4; ++k) {
    const std::vector<ObjectObservation> obs = fe.Process(t[k]);
    ASSERT_EQ(obs.size(), k == 2 ? 1u : 2u) << "frame " << k;
    for (const ObjectObservation& o : obs) {
      EXPECT_EQ(o.t_ns, t[k]);
      EXPECT_EQ(o.object_class, o.object_id == 1 ? ObjectClass::kDoor : ObjectClass::kTag);
      const Corners truth = TrueCorners(o.object_id, k);
      for (int j = 0; j < 4; ++j)
        EXPECT_EQ(o.corners[j], truth[j]) << "object " << o.object_id << " corner " << j;
    }
  }
  EXPECT_TRUE(fe.Process(t[3] + 1).empty());  // a time without rows
  EXPECT_EQ(fe.stats().rows, 8);
  EXPECT_EQ(fe.stats().rows_not_visible, 1);
  EXPECT_EQ(fe.stats().observations, 7);
  EXPECT_EQ(fe.stats().frames_matched, 4);
}

TEST(GtCorners, NotFullyVisibleRowsAreDropped) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  GtCornersFrontend fe(dir.string(), Sigma(1.0));
  const std::vector<ObjectObservation> obs = fe.Process(t[2]);
  ASSERT_EQ(obs.size(), 1u);
  EXPECT_EQ(obs[0].object_id, 1);
}

// An object partly in view is handed out with the corners it shows (at least
// min_visible_corners), its noise drawn from its own stream: the fully visible rows' noisy
// corners are those of a file without it.
TEST(GtCorners, PartlyVisibleRowsGiveTheCornersTheyShow) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  std::vector<CornerRow> rows = ReadCornerRows((dir / "observations_gt.csv").string());
  CornerRow partial = rows.back();  // object 2 in frame 3, now with corners s1 and s4 only
  rows.pop_back();
  WriteCornerRows(rows, (dir / "observations_gt.csv").string(), /*with_flag=*/true);
  GtCornersFrontend without(dir.string(), Sigma(1.0));
  partial.visible = {true, false, false, true};
  rows.push_back(partial);
  WriteCornerRows(rows, (dir / "observations_gt.csv").string(), /*with_flag=*/true);
  GtCornersOptions four = Sigma(1.0);
  four.min_visible_corners = 4;
  GtCornersFrontend with(dir.string(), Sigma(1.0)), whole_only(dir.string(), four);
  const std::vector<ObjectObservation> obs = with.Process(t[3]);
  ASSERT_EQ(obs.size(), 2u);
  EXPECT_TRUE(obs[0].Complete());
  EXPECT_EQ(obs[1].object_id, 2);
  EXPECT_EQ(obs[1].seen, (CornerMask{true, false, false, true}));
  EXPECT_LT((obs[1].corners[0] - TrueCorners(2, 3)[0]).norm(), 5.0);
  EXPECT_EQ(obs[0].corners, without.Process(t[3]).at(0).corners);  // its own noise stream
  EXPECT_EQ(with.stats().rows_partial, 1);
  EXPECT_EQ(with.stats().rows_not_visible, 1);  // object 2 in frame 2: one corner
  EXPECT_EQ(whole_only.Process(t[3]).size(), 1u);
  EXPECT_EQ(whole_only.stats().rows_not_visible, 2);
}

TEST(GtCorners, SameSeedSameNoiseOtherSeedOtherNoise) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  GtCornersFrontend a(dir.string(), Sigma(1.0, 7)), b(dir.string(), Sigma(1.0, 7)),
      c(dir.string(), Sigma(1.0, 8));
  double sum_sq = 0.0;
  int n = 0;
  for (int k = 0; k < 4; ++k) {
    const auto oa = a.Process(t[k]), ob = b.Process(t[k]), oc = c.Process(t[k]);
    ASSERT_EQ(oa.size(), ob.size());
    ASSERT_EQ(oa.size(), oc.size());
    for (size_t i = 0; i < oa.size(); ++i) {
      const Corners truth = TrueCorners(oa[i].object_id, k);
      for (int j = 0; j < 4; ++j) {
        EXPECT_EQ(oa[i].corners[j], ob[i].corners[j]);  // bit-identical
        EXPECT_NE(oa[i].corners[j], oc[i].corners[j]);
        const Vec2 d = oa[i].corners[j] - truth[j];
        EXPECT_LT(d.cwiseAbs().maxCoeff(), 5.0);  // 5 σ
        sum_sq += d.squaredNorm();
        n += 2;
      }
    }
  }
  // 56 draws of N(0, 1): the sample std lies in [0.7, 1.3] with probability > 0.999 (fixed seed
  // anyway).
  const double std_px = std::sqrt(sum_sq / n);
  EXPECT_GT(std_px, 0.7);
  EXPECT_LT(std_px, 1.3);
}

TEST(GtCorners, NoiseDoesNotDependOnWhichFramesAreProcessed) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  GtCornersFrontend all(dir.string(), Sigma(1.0)), some(dir.string(), Sigma(1.0));
  for (int k = 0; k < 3; ++k) all.Process(t[k]);
  const auto a = all.Process(t[3]), s = some.Process(t[3]);  // `some` skipped frames 0..2
  ASSERT_EQ(a.size(), s.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].corners[0], s[i].corners[0]);
}

TEST(GtCorners, FindsTheSequenceFromMav0) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  EXPECT_EQ(fs::path(SequenceRootOf((dir / "mav0").string())), dir);
  GtCornersFrontend fe((dir / "mav0").string(), Sigma(0.0));
  EXPECT_EQ(fe.Process(t[0]).size(), 2u);
}

TEST(GtCorners, ClearErrors) {
  const fs::path dir = test::ScratchDir();
  test::MakeEuroc(dir, 2);
  std::string e = ErrorOf([&] { GtCornersFrontend(dir.string(), Sigma(1.0)); });
  EXPECT_NE(e.find("gt-corners needs a rendered sequence"), std::string::npos) << e;
  EXPECT_NE(e.find("observations_gt.csv not found"), std::string::npos) << e;

  MakeSequence(dir);
  fs::remove(dir / "objects_gt.json");
  e = ErrorOf([&] { GtCornersFrontend(dir.string(), Sigma(1.0)); });
  EXPECT_NE(e.find("objects_gt.json not found"), std::string::npos) << e;

  WriteText(dir / "objects_gt.json", R"({"objects": [{"id": 1, "class": "door"}]})");
  e = ErrorOf([&] { GtCornersFrontend(dir.string(), Sigma(1.0)); });
  EXPECT_NE(e.find("object 2 is not in"), std::string::npos) << e;

  WriteText(dir / "objects_gt.json",
            R"({"objects": [{"id": 1, "class": "sofa"}, {"id": 2, "class": "tag"}]})");
  e = ErrorOf([&] { GtCornersFrontend(dir.string(), Sigma(1.0)); });
  EXPECT_NE(e.find("unknown class \"sofa\""), std::string::npos) << e;

  WriteText(dir / "objects_gt.json", R"({"objects": )");
  e = ErrorOf([&] { GtCornersFrontend(dir.string(), Sigma(1.0)); });
  EXPECT_NE(e.find("not valid JSON"), std::string::npos) << e;

  WriteText(dir / "objects_gt.json",
            R"({"objects": [{"id": 1, "class": "door"}, {"id": 2, "class": "tag"}]})");
  WriteText(dir / "observations_gt.csv", "0,1,1,2,3,4,5,6,7,8,1\n0,1,1,2,3,4,5,6,7\n");
  e = ErrorOf([&] { GtCornersFrontend(dir.string(), Sigma(1.0)); });
  EXPECT_NE(e.find("observations_gt.csv:2"), std::string::npos) << e;

  // The visible_corners column: 0..15, and all four bits exactly when fully_visible.
  WriteText(dir / "observations_gt.csv", "0,1,1,2,3,4,5,6,7,8,1,15\n0,2,1,2,3,4,5,6,7,8,0,16\n");
  e = ErrorOf([&] { GtCornersFrontend(dir.string(), Sigma(1.0)); });
  EXPECT_NE(e.find("observations_gt.csv:2: column 12 (visible_corners) must be 0..15"),
            std::string::npos)
      << e;
  WriteText(dir / "observations_gt.csv", "0,1,1,2,3,4,5,6,7,8,1,7\n");
  e = ErrorOf([&] { GtCornersFrontend(dir.string(), Sigma(1.0)); });
  EXPECT_NE(e.find("contradicts column 11 (fully_visible)"), std::string::npos) << e;

  e = ErrorOf([&] { GtCornersFrontend(dir.string(), Sigma(-1.0)); });
  EXPECT_NE(e.find("pixel_sigma"), std::string::npos) << e;
  GtCornersOptions one = Sigma(1.0);
  one.min_visible_corners = 1;
  e = ErrorOf([&] { GtCornersFrontend(dir.string(), one); });
  EXPECT_NE(e.find("min_visible_corners must be 2, 3 or 4"), std::string::npos) << e;
}

// A camera with lens distortion (the fixture's 32 x 24 px, EuRoC-like coefficients).
Calibration DistortedCalibration() {
  Calibration c = test::TestCalibration();
  c.camera.distortion = {-0.28, 0.07, 0.0002, 0.00002};
  return c;
}

// The corners file of MakeSequence's rows as a detector would report them: distorted by CAMERA.
void WriteDistortedCorners(const fs::path& path, const std::vector<int64_t>& t,
                           const PinholeRadtan& camera) {
  std::vector<CornerRow> rows;
  for (int k = 0; k < 4; ++k) {
    for (int id : {1, 2}) {
      CornerRow r;
      r.t_ns = t[k];
      r.object_id = id;
      const Corners truth = TrueCorners(id, k);
      for (int j = 0; j < 4; ++j) r.corners[j] = camera.DistortPixel(truth[j]);
      if (id == 2 && k == 2) {  // one corner in view: too few to be handed out
        r.visible = {true, false, false, false};
      }
      rows.push_back(r);
    }
  }
  WriteCornerRows(rows, path.string(), /*with_flag=*/true);
}

TEST(ExternalCorners, UndistortsWithTheCalibration) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  const Calibration calib = DistortedCalibration();
  WriteDistortedCorners(dir / "corners.csv", t, calib.camera);
  ExternalCornersFrontend fe((dir / "corners.csv").string(), "", calib, t);
  double max_err = 0.0, max_shift = 0.0;
  for (int k = 0; k < 4; ++k) {
    const std::vector<ObjectObservation> obs = fe.Process(t[k]);
    ASSERT_EQ(obs.size(), k == 2 ? 1u : 2u) << "frame " << k;
    for (const ObjectObservation& o : obs) {
      EXPECT_EQ(o.t_ns, t[k]);
      EXPECT_EQ(o.object_class, ObjectClass::kUnknown);  // no objects file
      const Corners truth = TrueCorners(o.object_id, k);
      for (int j = 0; j < 4; ++j) {
        max_err = std::max(max_err, (o.corners[j] - truth[j]).norm());
        max_shift = std::max(max_shift, (calib.camera.DistortPixel(truth[j]) - truth[j]).norm());
      }
    }
  }
  EXPECT_GT(max_shift, 0.3);  // the distortion is large enough to matter ...
  EXPECT_LT(max_err, 2e-4);   // ... and undone (the file holds 4 decimals)
  EXPECT_EQ(fe.stats().rows, 8);
  EXPECT_EQ(fe.stats().rows_not_visible, 1);
  EXPECT_EQ(fe.stats().frames_matched, 4);
  EXPECT_EQ(fe.stats().observations, 7);
}

TEST(ExternalCorners, WithoutDistortionTheCornersAreTheFilesAndClassesComeFromObjects) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  // observations_gt.csv and objects_gt.json as another detector's output: what gt-corners gives
  // with σ = 0, bit for bit.
  ExternalCornersFrontend fe((dir / "observations_gt.csv").string(),
                             (dir / "objects_gt.json").string(), test::TestCalibration(), t);
  GtCornersFrontend gt(dir.string(), Sigma(0.0));
  for (int k = 0; k < 4; ++k) {
    const std::vector<ObjectObservation> a = fe.Process(t[k]), b = gt.Process(t[k]);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].object_id, b[i].object_id);
      EXPECT_EQ(a[i].object_class, b[i].object_class);
      for (int j = 0; j < 4; ++j) EXPECT_EQ(a[i].corners[j], b[i].corners[j]);
    }
  }
}

TEST(ExternalCorners, TimesAreTheInputsBeforeTheTimeOffset) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  Calibration calib = test::TestCalibration();
  calib.time_offset_ns = 1000;
  std::vector<int64_t> frames = t;  // the frame times as the source reports them: offset added
  for (int64_t& f : frames) f += calib.time_offset_ns;
  ExternalCornersFrontend fe((dir / "observations_gt.csv").string(), "", calib, frames);
  EXPECT_EQ(fe.Process(frames[0]).size(), 2u);
  EXPECT_EQ(fe.Process(frames[0])[0].t_ns, frames[0]);
  EXPECT_TRUE(fe.Process(t[1]).empty());
}

TEST(ExternalCorners, ClearErrors) {
  const fs::path dir = test::ScratchDir();
  const std::vector<int64_t> t = MakeSequence(dir);
  const Calibration calib = test::TestCalibration();
  const fs::path file = dir / "corners.csv";
  const auto error = [&](const std::string& objects = "") {
    return ErrorOf([&] { ExternalCornersFrontend(file.string(), objects, calib, t); });
  };
  const std::string t0 = std::to_string(t[0]), t1 = std::to_string(t[1]);

  std::string e = error();
  EXPECT_NE(e.find("corners.csv: corners file not found"), std::string::npos) << e;

  WriteText(file, "# t_ns,object_id,u1,v1,u2,v2,u3,v3,u4,v4\n");
  e = error();
  EXPECT_NE(e.find("corners.csv: no rows"), std::string::npos) << e;

  WriteText(file, t0 + ",1,1,2,3,4,5,6,7,8\n" + t0 + ",2,1,2,3,4,5,6,7\n");
  e = error();
  EXPECT_NE(e.find("corners.csv:2"), std::string::npos) << e;

  WriteText(file, t0 + ",1,1,2,3,4,5,6,7,8\n" + t0 + ",2,1,2,3,nan,5,6,7,8\n");
  e = error();
  EXPECT_NE(e.find("corners.csv:2: column 6 (v2) is not finite"), std::string::npos) << e;

  WriteText(file, t1 + ",1,1,2,3,4,5,6,7,8\n" + t0 + ",1,1,2,3,4,5,6,7,8\n");
  e = error();
  EXPECT_NE(e.find("corners.csv:2: timestamp " + t0 + " goes backwards"), std::string::npos) << e;

  WriteText(file, t0 + ",1,1,2,3,4,5,6,7,8\n" + std::to_string(t[0] + 7) + ",1,1,2,3,4,5,6,7,8\n");
  e = error();
  EXPECT_NE(e.find("corners.csv:2: t_ns " + std::to_string(t[0] + 7) +
                   " matches no frame of the input; its frames span [" + t0 + ", " +
                   std::to_string(t[3]) + "] ns"),
            std::string::npos)
      << e;

  WriteText(file, t0 + ",1,1,2,3,4,5,6,7,8\n" + t0 + ",1,1,2,3,4,5,6,7,8\n");
  e = error();
  EXPECT_NE(e.find("corners.csv:2: object 1 appears twice at t_ns " + t0), std::string::npos) << e;

  WriteText(file, t0 + ",1,1,2,3,4,5,6,7,8\n" + t0 + ",3,1,2,3,4,5,6,7,8\n");
  e = error((dir / "objects_gt.json").string());
  EXPECT_NE(e.find("corners.csv:2: object 3 is not in"), std::string::npos) << e;
  const ExternalCornersFrontend any_id(file.string(), "", calib, t);  // no objects file: any id
  EXPECT_EQ(any_id.stats().rows, 2);
}

}  // namespace
}  // namespace fsp::apps
