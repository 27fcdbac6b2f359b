// OpenSource: recognises the kind of INPUT, validates it and merges frames and IMU in time order.
#include "fsp/common/dataset.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "dataset_internal.h"
#include "fsp/common/error.h"

namespace fsp {

namespace fs = std::filesystem;

namespace {

// One implementation for every kind: the kinds differ only in how frames are listed and decoded.
class RecordedSource : public Source {
 public:
  RecordedSource(InputKind kind, Calibration calib, internal::FrameList frames,
                 std::vector<ImuSample> imu, bool decode)
      : kind_(kind),
        calib_(std::move(calib)),
        decoder_(std::move(frames.decoder)),
        imu_(std::move(imu)),
        decode_(decode) {
    frame_times_ = std::move(frames.t_ns);
    for (int64_t& t : frame_times_) t += calib_.time_offset_ns;
  }

  InputKind kind() const override { return kind_; }
  const Calibration& calibration() const override { return calib_; }
  const std::vector<int64_t>& frame_times() const override { return frame_times_; }
  const std::vector<ImuSample>& imu() const override { return imu_; }

  std::optional<Measurement> Next() override {
    const bool imu_left = next_imu_ < imu_.size();
    const bool frame_left = next_frame_ < frame_times_.size();
    if (!imu_left && !frame_left) return std::nullopt;
    // IMU samples at or before the next frame's time come first.
    if (imu_left && (!frame_left || imu_[next_imu_].t_ns <= frame_times_[next_frame_])) {
      return Measurement(imu_[next_imu_++]);
    }
    const int index = static_cast<int>(next_frame_++);
    if (decode_) return Measurement(ReadFrame(index));
    Frame frame;
    frame.t_ns = frame_times_[static_cast<size_t>(index)];
    frame.index = index;
    frame.source = decoder_->Name(index);
    return Measurement(std::move(frame));
  }

  Frame ReadFrame(int index) const override {
    FSP_CHECK(index >= 0 && index < static_cast<int>(frame_times_.size()));
    Frame frame;
    frame.t_ns = frame_times_[static_cast<size_t>(index)];
    frame.index = index;
    frame.source = decoder_->Name(index);
    frame.image = decoder_->Decode(index);
    const PinholeRadtan& cam = calib_.camera;
    if (frame.image.cols != cam.width || frame.image.rows != cam.height) {
      throw InputError(frame.source, 0,
                       "image size " + std::to_string(frame.image.cols) + "x" +
                           std::to_string(frame.image.rows) + " differs from the calibration's " +
                           std::to_string(cam.width) + "x" + std::to_string(cam.height) + " (" +
                           calib_.source + ")");
    }
    return frame;
  }

 private:
  InputKind kind_;
  Calibration calib_;
  std::unique_ptr<internal::FrameDecoder>
      decoder_;  // decoding advances a video reader: not logically const
  std::vector<int64_t> frame_times_;
  std::vector<ImuSample> imu_;
  bool decode_ = true;
  size_t next_imu_ = 0;
  size_t next_frame_ = 0;
};

bool IsDir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}
bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

// Fails unless frames and IMU share some time (a clock mix-up would otherwise run silently wrong).
void CheckOverlap(const std::vector<int64_t>& frames, const std::vector<ImuSample>& imu,
                  const std::string& imu_path, const Calibration& calib) {
  if (frames.back() < imu.front().t_ns || frames.front() > imu.back().t_ns) {
    throw InputError(imu_path, 0,
                     "IMU samples span [" + std::to_string(imu.front().t_ns) + ", " +
                         std::to_string(imu.back().t_ns) + "] ns but the frames span [" +
                         std::to_string(frames.front()) + ", " + std::to_string(frames.back()) +
                         "] ns: no overlap in time (check the clocks, time_offset_ns in " +
                         calib.source + " or --frame-times)");
  }
}

// Fails unless every time the pipeline forms fits in int64 nanoseconds: a frame time plus the
// calibration's time offset, and the difference of any two frame or IMU times (frames and IMU
// together span less than 292 years). FRAMES and IMU are in increasing time order.
void CheckTimeRange(const std::vector<int64_t>& frames, const std::vector<ImuSample>& imu,
                    const std::string& first_frame, const std::string& imu_path,
                    const Calibration& calib) {
  int64_t first = 0, last = 0;
  if (__builtin_add_overflow(frames.front(), calib.time_offset_ns, &first) ||
      __builtin_add_overflow(frames.back(), calib.time_offset_ns, &last)) {
    throw InputError(calib.source, 0,
                     "time_offset_ns " + std::to_string(calib.time_offset_ns) +
                         " moves the frame times (" + std::to_string(frames.front()) + " to " +
                         std::to_string(frames.back()) + " ns, the first frame " + first_frame +
                         ") out of the range of int64 nanoseconds");
  }
  const int64_t lo = std::min(first, imu.front().t_ns), hi = std::max(last, imu.back().t_ns);
  int64_t span = 0;
  if (__builtin_sub_overflow(hi, lo, &span)) {
    throw InputError(imu_path, 0,
                     "the frames (the first " + first_frame + ") and the IMU samples span " +
                         std::to_string(lo) + " to " + std::to_string(hi) +
                         " ns, more than 292 years: are the timestamps nanoseconds?");
  }
}

std::unique_ptr<Source> Finish(InputKind kind, Calibration calib, internal::FrameList frames,
                               const std::string& imu_path, const SourceOptions& options) {
  if (options.time_offset_ns) calib.time_offset_ns = *options.time_offset_ns;
  std::vector<ImuSample> imu = ReadImuCsv(imu_path);
  CheckTimeRange(frames.t_ns, imu, frames.decoder->Name(0), imu_path, calib);
  auto source = std::make_unique<RecordedSource>(kind, std::move(calib), std::move(frames),
                                                 std::move(imu), options.decode_images);
  CheckOverlap(source->frame_times(), source->imu(), imu_path, source->calibration());
  source->ReadFrame(0);  // the first image decodes and fits the calibration
  return source;
}

std::unique_ptr<Source> OpenEuroc(const fs::path& mav0, const SourceOptions& options) {
  const fs::path cam0 = mav0 / "cam0";
  Calibration calib;
  if (!options.calib.empty()) {
    calib = ReadCalibration(options.calib);
  } else {
    const fs::path yaml = cam0 / "sensor.yaml";
    if (!IsFile(yaml))
      throw InputError(yaml.string(), 0, "camera calibration not found (or pass --calib FILE)");
    calib = ReadCalibration(yaml.string());
  }
  const fs::path imu_yaml = mav0 / "imu0" / "sensor.yaml";
  if (calib.imu_source.empty() && IsFile(imu_yaml)) {
    calib.imu = ReadImuNoise(imu_yaml.string());
    calib.imu_source = imu_yaml.string();
  }
  const fs::path csv = cam0 / "data.csv";
  if (!IsFile(csv)) throw InputError(csv.string(), 0, "EuRoC image list not found");
  internal::FrameList frames = internal::ListImagesFromCsv(csv.string(), (cam0 / "data").string());
  const std::string imu_path =
      !options.imu.empty() ? options.imu : (mav0 / "imu0" / "data.csv").string();
  return Finish(InputKind::kEuroc, std::move(calib), std::move(frames), imu_path, options);
}

// A DSO / TUM-VI / DM-VIO layout: DIR/cam0 holds times.txt, camera.txt or images/ (and not
// EuRoC's data.csv).
bool IsDsoLayout(const fs::path& dir) {
  const fs::path cam0 = dir / "cam0";
  return !IsFile(cam0 / "data.csv") &&
         (IsFile(cam0 / "times.txt") || IsFile(cam0 / "camera.txt") || IsDir(cam0 / "images"));
}

// The IMU noise of a DSO layout whose camchain has none: the first YAML file beside it (by name)
// that mentions a noise density, such as DM-VIO's settings file (d435.yaml, ...).
void ReadImuNoiseBeside(const fs::path& dir, const fs::path& camchain, Calibration* calib) {
  std::vector<fs::path> yamls;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    const std::string ext = e.path().extension().string();
    if ((ext == ".yaml" || ext == ".yml") && e.path() != camchain && IsFile(e.path()))
      yamls.push_back(e.path());
  }
  std::sort(yamls.begin(), yamls.end());
  for (const fs::path& p : yamls) {
    std::ifstream in(p);
    std::ostringstream text;
    text << in.rdbuf();
    if (text.str().find("noise_density") == std::string::npos) continue;
    calib->imu = ReadImuNoise(p.string());
    calib->imu_source = p.string();
    return;
  }
}

std::unique_ptr<Source> OpenDso(const fs::path& dir, const SourceOptions& options) {
  const fs::path cam0 = dir / "cam0";
  const fs::path times = cam0 / "times.txt";
  const fs::path camera_txt = cam0 / "camera.txt";
  const fs::path camchain = dir / "camchain.yaml";
  if (!IsFile(times)) {
    throw InputError(times.string(), 0,
                     "DSO frame list not found (rows 'id t_s [exposure_ms]'; images in " +
                         (cam0 / "images").string() + ")");
  }
  internal::FrameList frames =
      internal::ListImagesFromDsoTimes(times.string(), (cam0 / "images").string());
  Calibration calib;
  if (!options.calib.empty()) {
    calib = ReadCalibration(options.calib);
    if (calib.imu_source.empty() && IsFile(camchain)) {
      const Calibration chain = ReadKalibrCameraImu(camchain.string());
      calib.imu = chain.imu;
      calib.imu_source = chain.imu_source;
    }
  } else {
    // Intrinsics from camera.txt (the file beside the images, the one DSO and DM-VIO read them
    // from); T_B_C, time shift and IMU noise from the camchain, whose intrinsics are not read.
    if (!IsFile(camera_txt))
      throw InputError(camera_txt.string(), 0,
                       "camera calibration not found (or pass --calib FILE)");
    if (!IsFile(camchain)) {
      throw InputError(camchain.string(), 0,
                       "camera-IMU calibration not found (Kalibr camchain with cam0: T_cam_imu; or "
                       "pass --calib FILE)");
    }
    calib = ReadKalibrCameraImu(camchain.string());
    calib.camera = ReadDsoCamera(camera_txt.string());
    calib.source = camera_txt.string() + ", " + camchain.string();
    if (frames.t_ns.size() >= 2) {
      std::vector<int64_t> dt;
      for (size_t i = 1; i < frames.t_ns.size(); ++i)
        dt.push_back(frames.t_ns[i] - frames.t_ns[i - 1]);
      std::nth_element(dt.begin(), dt.begin() + static_cast<long>(dt.size() / 2), dt.end());
      calib.camera_rate_hz = 1e9 / static_cast<double>(dt[dt.size() / 2]);
    }
    std::string why;
    if (!calib.Check(&why)) throw InputError(calib.source, 0, why);
  }
  if (calib.imu_source.empty()) ReadImuNoiseBeside(dir, camchain, &calib);
  const fs::path imu_txt = dir / "imu.txt";
  if (options.imu.empty() && !IsFile(imu_txt)) {
    throw InputError(imu_txt.string(), 0,
                     "IMU samples not found (rows 't_ns wx wy wz ax ay az'; or pass --imu FILE)");
  }
  const std::string imu_path = !options.imu.empty() ? options.imu : imu_txt.string();
  return Finish(InputKind::kDso, std::move(calib), std::move(frames), imu_path, options);
}

void RequireCalibAndImu(const SourceOptions& options, const char* what) {
  if (options.calib.empty() || options.imu.empty()) {
    throw InputError(options.input, 0, std::string(what) + " needs --calib FILE and --imu FILE");
  }
}

std::unique_ptr<Source> OpenImageFolder(const fs::path& dir, const SourceOptions& options) {
  RequireCalibAndImu(options, "an image folder (not a EuRoC mav0 layout)");
  Calibration calib = ReadCalibration(options.calib);
  const fs::path csv = dir / "data.csv";
  internal::FrameList frames;
  if (IsFile(csv)) {
    // EuRoC cam0 style: names relative to DIR/data/ when the images are there, else to DIR.
    fs::path image_dir = dir;
    if (IsDir(dir / "data")) {
      TableReader probe(csv.string(), "image list");
      std::vector<std::string> f;
      if (probe.NextRow(&f) && f.size() >= 2 && IsFile(dir / "data" / f[1]))
        image_dir = dir / "data";
    }
    frames = internal::ListImagesFromCsv(csv.string(), image_dir.string());
  } else {
    frames = internal::ListImagesByName(dir.string());
  }
  return Finish(InputKind::kImageFolder, std::move(calib), std::move(frames), options.imu, options);
}

std::unique_ptr<Source> OpenVideo(const fs::path& file, const SourceOptions& options) {
  RequireCalibAndImu(options, "a video");
  Calibration calib = ReadCalibration(options.calib);
  internal::FrameList frames = internal::ScanVideo(file.string(), options.frame_times);
  return Finish(InputKind::kVideo, std::move(calib), std::move(frames), options.imu, options);
}

}  // namespace

const char* ToString(InputKind kind) {
  switch (kind) {
    case InputKind::kEuroc:
      return "euroc";
    case InputKind::kVideo:
      return "video";
    case InputKind::kImageFolder:
      return "image-folder";
    case InputKind::kDso:
      return "dso";
  }
  return "?";
}

bool SourceOptions::Check(std::string* why) const {
  std::string w;
  if (input.empty())
    w = "no input given";
  else if (!frame_times.empty() && IsDir(input))
    w = "--frame-times applies to a video input only";
  if (why) *why = w;
  return w.empty();
}

std::unique_ptr<Source> OpenSource(const SourceOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InputError(options.input, 0, why);
  const fs::path input(options.input);
  std::error_code ec;
  if (!fs::exists(input, ec)) throw InputError(options.input, 0, "input not found");
  if (IsDir(input)) {
    if (IsDir(input / "mav0" / "cam0")) return OpenEuroc(input / "mav0", options);
    if (IsDsoLayout(input)) return OpenDso(input, options);
    if (IsDir(input / "cam0")) return OpenEuroc(input, options);
    return OpenImageFolder(input, options);
  }
  return OpenVideo(input, options);
}

SourceSummary Summarize(const Source& source) {
  SourceSummary s;
  s.kind = source.kind();
  const std::vector<int64_t>& ft = source.frame_times();
  const std::vector<ImuSample>& imu = source.imu();
  const auto median_rate = [](std::vector<int64_t> dt) {
    if (dt.empty()) return 0.0;
    std::nth_element(dt.begin(), dt.begin() + static_cast<long>(dt.size() / 2), dt.end());
    const int64_t m = dt[dt.size() / 2];
    return m > 0 ? 1e9 / static_cast<double>(m) : 0.0;
  };
  s.frames = static_cast<int>(ft.size());
  if (!ft.empty()) {
    s.t_first_ns = ft.front();
    s.t_last_ns = ft.back();
    std::vector<int64_t> dt;
    for (size_t i = 1; i < ft.size(); ++i) dt.push_back(ft[i] - ft[i - 1]);
    s.frame_rate_hz = median_rate(std::move(dt));
  }
  s.imu_samples = static_cast<int>(imu.size());
  if (!imu.empty()) {
    s.imu_t_first_ns = imu.front().t_ns;
    s.imu_t_last_ns = imu.back().t_ns;
    // A gap is an interval longer than 5 nominal IMU periods.
    const double gap_ns = 5.0 * 1e9 / source.calibration().imu.rate_hz;
    std::vector<int64_t> dt;
    for (size_t i = 1; i < imu.size(); ++i) {
      const int64_t d = imu[i].t_ns - imu[i - 1].t_ns;
      dt.push_back(d);
      if (d > s.largest_imu_gap_ns) {
        s.largest_imu_gap_ns = d;
        s.largest_imu_gap_at_ns = imu[i].t_ns;
      }
      if (static_cast<double>(d) > gap_ns) ++s.imu_gaps;
    }
    s.imu_rate_hz = median_rate(std::move(dt));
    for (int64_t t : ft) {
      if (t < s.imu_t_first_ns || t > s.imu_t_last_ns) ++s.frames_outside_imu;
    }
  }
  return s;
}

}  // namespace fsp
