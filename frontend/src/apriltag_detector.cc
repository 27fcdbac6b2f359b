#include "fsp/frontend/apriltag_detector.h"

#include <cmath>
#include <sstream>

extern "C" {
#include <apriltag.h>
#include <tag16h5.h>
#include <tag25h9.h>
#include <tag36h11.h>
#include <tagCircle21h7.h>
#include <tagCircle49h12.h>
#include <tagCustom48h12.h>
#include <tagStandard41h12.h>
#include <tagStandard52h13.h>
}

#include "fsp/common/error.h"

namespace fsp::frontend {

namespace {
struct FamilyEntry {
  const char* name;
  apriltag_family_t* (*create)();
  void (*destroy)(apriltag_family_t*);
};
const FamilyEntry kFamilies[] = {
    {"tag36h11", tag36h11_create, tag36h11_destroy},
    {"tag25h9", tag25h9_create, tag25h9_destroy},
    {"tag16h5", tag16h5_create, tag16h5_destroy},
    {"tagCircle21h7", tagCircle21h7_create, tagCircle21h7_destroy},
    {"tagCircle49h12", tagCircle49h12_create, tagCircle49h12_destroy},
    {"tagStandard41h12", tagStandard41h12_create, tagStandard41h12_destroy},
    {"tagStandard52h13", tagStandard52h13_create, tagStandard52h13_destroy},
    {"tagCustom48h12", tagCustom48h12_create, tagCustom48h12_destroy},
};
}  // namespace

bool AprilTagDetectorOptions::Check(std::string* why) const {
  std::ostringstream os;
  if (!(decimate >= 1.0) || !std::isfinite(decimate)) os << "decimate must be >= 1; ";
  if (!(sigma >= 0.0)) os << "sigma must be >= 0; ";
  if (threads < 1) os << "threads must be >= 1; ";
  if (max_hamming < 0 || max_hamming > 3) os << "max_hamming must be in [0, 3]; ";
  if (!(decode_sharpening >= 0.0)) os << "decode_sharpening must be >= 0; ";
  if (why) *why = os.str();
  return os.str().empty();
}

struct AprilTagDetector::Impl {
  const FamilyEntry* entry = nullptr;
  apriltag_family_t* family = nullptr;
  apriltag_detector_t* detector = nullptr;
  ~Impl() {
    if (detector) apriltag_detector_destroy(detector);
    if (family) entry->destroy(family);
  }
};

std::vector<std::string> AprilTagDetector::Families() {
  std::vector<std::string> names;
  for (const auto& f : kFamilies) names.emplace_back(f.name);
  return names;
}

AprilTagDetector::AprilTagDetector(Options options)
    : options_(std::move(options)), impl_(new Impl) {
  std::string why;
  FSP_CHECK(options_.Check(&why));
  for (const auto& f : kFamilies)
    if (options_.family == f.name) impl_->entry = &f;
  if (!impl_->entry) {
    std::string all;
    for (const auto& n : Families()) all += (all.empty() ? "" : ", ") + n;
    throw InputError("unknown AprilTag family '" + options_.family + "' (known: " + all + ")");
  }
  impl_->family = impl_->entry->create();
  impl_->detector = apriltag_detector_create();
  apriltag_detector_add_family_bits(impl_->detector, impl_->family, options_.max_hamming);
  impl_->detector->quad_decimate = static_cast<float>(options_.decimate);
  impl_->detector->quad_sigma = static_cast<float>(options_.sigma);
  impl_->detector->refine_edges = options_.refine_edges;
  impl_->detector->decode_sharpening = options_.decode_sharpening;
  impl_->detector->nthreads = options_.threads;
  impl_->detector->debug = false;
}

AprilTagDetector::~AprilTagDetector() = default;

AprilTagDetector::Result AprilTagDetector::Detect(const cv::Mat& gray,
                                                  const PinholeRadtan* camera) const {
  FSP_CHECK(gray.type() == CV_8UC1 && !gray.empty());
  Result res;
  Stopwatch sw;
  // libapriltag reads the buffer only; the cast drops const for its C struct.
  image_u8_t im{gray.cols, gray.rows, static_cast<int32_t>(gray.step[0]),
                const_cast<uint8_t*>(gray.ptr<uint8_t>(0))};
  zarray_t* dets = apriltag_detector_detect(impl_->detector, &im);
  res.times.Add("apriltag", sw.Lap());
  const bool distort = camera && camera->HasDistortion();
  for (int i = 0; i < zarray_size(dets); ++i) {
    apriltag_detection_t* d = nullptr;
    zarray_get(dets, i, &d);
    if (d->decision_margin < options_.min_decision_margin) continue;
    Detection det;
    det.tag_id = d->id;
    det.object_class = ObjectClass::kTag;
    for (int k = 0; k < 4; ++k) {
      // libapriltag: pixel (0,0) covers [0,1)², its centre is (0.5, 0.5) -> subtract 0.5 (OpenCV
      // centres).
      det.corners_px[k] = Vec2(d->p[k][0] - 0.5, d->p[k][1] - 0.5);
      det.corners_undistorted[k] =
          distort ? camera->UndistortPixel(det.corners_px[k]) : det.corners_px[k];
    }
    det.score = d->decision_margin / (d->decision_margin + 50.0);
    res.detections.push_back(det);
  }
  apriltag_detections_destroy(dets);
  res.times.Add("convert", sw.Lap());
  return res;
}

}  // namespace fsp::frontend
