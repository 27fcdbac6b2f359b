// FolderFollower: an image folder (and its IMU csv) followed while a camera driver fills it.
#include "fsp/common/folder_follower.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <thread>

#include "dataset_internal.h"
#include "fsp/common/error.h"

namespace fsp {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t, Clock::time_point now) {
  return std::chrono::duration<double>(now - t).count();
}

bool IsImageName(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm" || ext == ".bmp";
}

// The timestamp of a name <digits>.<ext>; nullopt otherwise.
std::optional<int64_t> TimestampOf(const fs::path& p) {
  const std::string stem = p.stem().string();
  if (stem.empty() ||
      !std::all_of(stem.begin(), stem.end(), [](unsigned char c) { return std::isdigit(c); }))
    return std::nullopt;
  errno = 0;
  const long long t = std::strtoll(stem.c_str(), nullptr, 10);
  if (errno == ERANGE) return std::nullopt;
  return static_cast<int64_t>(t);
}

}  // namespace

const char* ToString(FollowEnd end) {
  switch (end) {
    case FollowEnd::kRunning:
      return "running";
    case FollowEnd::kIdle:
      return "idle";
    case FollowEnd::kStopped:
      return "stopped";
    case FollowEnd::kFolderGone:
      return "folder-gone";
    case FollowEnd::kError:
      return "error";
  }
  return "?";
}

bool FollowOptions::Check(std::string* why) const {
  std::string w;
  if (folder.empty())
    w = "no folder given";
  else if (calib.empty() || imu.empty())
    w = "following a folder needs --calib FILE and --imu FILE";
  else if (!(idle_s > 0.0))
    w = "the idle time must be > 0 s";
  else if (!(poll_s > 0.0 && poll_s <= 1.0))
    w = "the polling period must be in (0, 1] s";
  else if (!(imu_wait_s >= 0.0) || !(stale_s > 0.0))
    w = "the IMU wait must be >= 0 s and the stale time > 0 s";
  if (why) *why = w;
  return w.empty();
}

struct FolderFollower::Impl {
  struct Pending {
    std::string path;
    uintmax_t size = 0;
    bool stable = false;  // the same size in two polls
    Clock::time_point changed;
    std::optional<Clock::time_point> complete_since;  // complete, waiting for the IMU
  };

  FollowOptions o;
  Calibration calib;
  std::map<int64_t, Pending> pending;  // by file time (camera clock)
  std::map<std::string, int64_t> pending_by_path;
  std::set<std::string> known;   // every image path seen (pending, given out or skipped)
  std::set<int64_t> times_seen;  // file times seen
  Clock::time_point last_new;    // when the last new image file appeared
  // IMU csv
  uintmax_t imu_offset = 0;  // bytes consumed (complete lines)
  int imu_line = 0;          // lines consumed
  int imu_prev_line = 0;
  std::optional<ImuSample> imu_last;  // the last sample read
  std::deque<ImuSample> imu;          // read, not yet given out
  // Given out
  std::deque<Measurement> ready;
  int64_t last_frame_t = 0;
  int frames = 0, imu_given = 0, skipped = 0, imu_dropped = 0;
  static constexpr int kMaxNameWarnings = 5;
  int bad_names = 0;  // image names that are not timestamps
  int64_t t_first = 0;
  FollowEnd end = FollowEnd::kRunning;
  std::string message;

  void Warn(const std::string& w) const {
    if (o.warn) o.warn(w);
  }

  void Erase(std::map<int64_t, Pending>::iterator it) {
    pending_by_path.erase(it->second.path);
    pending.erase(it);
  }

  void Skip(std::map<int64_t, Pending>::iterator it, const std::string& why) {
    Warn(it->second.path + ": " + why + ": skipped");
    ++skipped;
    Erase(it);
  }

  // Lists the folder and reads the IMU csv's new complete lines.
  void Poll(Clock::time_point now) {
    std::error_code ec;
    if (!fs::is_directory(o.folder, ec)) {
      end = FollowEnd::kFolderGone;
      message = o.folder + ": the followed folder disappeared";
      return;
    }
    std::set<std::string> present;  // pending images still there
    for (fs::directory_iterator it(o.folder, ec), last; !ec && it != last; it.increment(ec)) {
      const fs::path& p = it->path();
      if (!IsImageName(p)) continue;
      std::string path = p.string();
      const auto in_pending = pending_by_path.find(path);
      const bool is_new = !known.count(path);
      if (!is_new && in_pending == pending_by_path.end()) continue;  // taken or skipped: no stat
      std::error_code ec2;
      if (!it->is_regular_file(ec2)) continue;
      const uintmax_t size = it->file_size(ec2);
      if (ec2) continue;  // removed meanwhile
      if (!is_new) {
        present.insert(path);
        Pending& q = pending.at(in_pending->second);
        q.stable = size == q.size && size > 0;
        if (size != q.size) {
          q.size = size;
          q.changed = now;
          q.complete_since.reset();
        }
        continue;
      }
      known.insert(path);
      last_new = now;
      const std::optional<int64_t> t = TimestampOf(p);
      if (!t) {
        if (++bad_names <= kMaxNameWarnings)
          Warn(path + ": image file name is not a nanosecond timestamp: ignored" +
               (bad_names == kMaxNameWarnings ? " (further such names are ignored silently)" : ""));
        continue;
      }
      if (!times_seen.insert(*t).second) {
        Warn(path + ": duplicate timestamp " + std::to_string(*t) + ": skipped");
        ++skipped;
        continue;
      }
      present.insert(path);
      Pending& q = pending[*t];
      q.path = path;
      q.size = size;
      q.changed = now;
      pending_by_path[path] = *t;
    }
    if (ec) {
      if (!fs::is_directory(o.folder)) {
        end = FollowEnd::kFolderGone;
        message = o.folder + ": the followed folder disappeared";
      }
      return;  // a listing that failed otherwise: try again at the next poll
    }
    // Images removed before they were taken.
    for (auto it = pending.begin(); it != pending.end();) {
      if (present.count(it->second.path)) {
        ++it;
      } else {
        Warn(it->second.path + ": removed before it was read: skipped");
        ++skipped;
        pending_by_path.erase(it->second.path);
        it = pending.erase(it);
      }
    }
    ReadImu();
  }

  void ReadImu() {
    std::error_code ec;
    if (!fs::is_regular_file(o.imu, ec)) {
      end = FollowEnd::kFolderGone;
      message = o.imu + ": the IMU csv disappeared";
      return;
    }
    const uintmax_t size = fs::file_size(o.imu, ec);
    if (ec || size == imu_offset) return;
    if (size < imu_offset) {
      end = FollowEnd::kError;
      message = o.imu + ": the IMU csv shrank while followed (rewritten?)";
      return;
    }
    std::ifstream in(o.imu, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(imu_offset));
    std::string text(size - imu_offset, '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<size_t>(in.gcount()));
    const size_t last_newline = text.rfind('\n');
    if (last_newline == std::string::npos) return;  // no complete line yet
    text.resize(last_newline + 1);
    std::vector<ImuSample> rows;
    if (imu_last) rows.push_back(*imu_last);
    try {
      TableReader reader(o.imu, "IMU csv", text, imu_line);
      internal::ReadImuRows(reader, &rows, &imu_prev_line);
    } catch (const InputError& e) {
      // The rows before the bad line stand (the frames they cover are still given out).
      end = FollowEnd::kError;
      message = e.what();
    }
    imu_offset += text.size();
    imu_line += static_cast<int>(std::count(text.begin(), text.end(), '\n'));
    for (size_t i = imu_last ? 1 : 0; i < rows.size(); ++i) {
      if (frames > 0 && rows[i].t_ns <= last_frame_t) {
        if (imu_dropped++ == 0)
          Warn(o.imu + ": IMU samples arrived after a later frame was processed: dropped");
        continue;
      }
      imu.push_back(rows[i]);
    }
    if (!rows.empty()) imu_last = rows.back();
  }

  void GiveImuUpTo(int64_t t) {
    while (!imu.empty() && imu.front().t_ns <= t) {
      ready.emplace_back(imu.front());
      imu.pop_front();
      ++imu_given;
    }
  }

  // Moves the frames that can go (complete, IMU read up to their time) to `ready`; ENDING: every
  // frame still waiting, then the IMU samples left.
  void Release(Clock::time_point now, bool ending,
               int64_t up_to = std::numeric_limits<int64_t>::max()) {
    while (!pending.empty()) {
      auto it = pending.begin();
      if (it->first + calib.time_offset_ns > up_to) break;
      Pending& q = it->second;
      const bool complete = ending || q.stable || SecondsSince(q.changed, now) >= o.stale_s;
      if (!complete) break;
      const int64_t t = it->first + calib.time_offset_ns;
      if (frames > 0 && t <= last_frame_t) {
        Skip(it, "arrived after a later frame was processed");
        continue;
      }
      const bool imu_covers = imu_last && imu_last->t_ns >= t;
      if (!ending && !imu_covers) {
        if (!q.complete_since) q.complete_since = now;
        if (SecondsSince(*q.complete_since, now) < o.imu_wait_s) break;
      }
      Frame frame;
      try {
        frame.image = internal::ReadGreyImage(q.path);
      } catch (const InputError& e) {
        std::error_code ec;
        if (!fs::is_directory(o.folder, ec)) {  // not a bad image: the folder went away
          end = FollowEnd::kFolderGone;
          message = o.folder + ": the followed folder disappeared";
          break;
        }
        const uintmax_t size = fs::file_size(q.path, ec);
        if (!ec && size != q.size && !ending) {
          // Still being written: wait for it.
          q.size = size;
          q.stable = false;
          q.changed = now;
          q.complete_since.reset();
          break;
        }
        // A writer that paused longer than a poll between two writes: try again until the file
        // has not changed for stale_s.
        if (!ec && !ending && SecondsSince(q.changed, now) < o.stale_s) break;
        Warn(std::string(e.what()) + ": skipped");
        ++skipped;
        Erase(it);
        continue;
      }
      const PinholeRadtan& cam = calib.camera;
      if (frame.image.cols != cam.width || frame.image.rows != cam.height) {
        const std::string what = "image size " + std::to_string(frame.image.cols) + "x" +
                                 std::to_string(frame.image.rows) +
                                 " differs from the calibration's " + std::to_string(cam.width) +
                                 "x" + std::to_string(cam.height) + " (" + calib.source + ")";
        if (frames == 0) throw InputError(q.path, 0, what);
        Skip(it, what);
        continue;
      }
      GiveImuUpTo(t);
      frame.t_ns = t;
      frame.index = frames;
      frame.source = q.path;
      if (frames == 0) t_first = t;
      ++frames;
      last_frame_t = t;
      ready.emplace_back(std::move(frame));
      Erase(it);
    }
    if (ending) GiveImuUpTo(up_to);
  }
};

FolderFollower::FolderFollower(const FollowOptions& options) : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.Check(&why)) throw InputError(options.folder, 0, why);
  impl_->o = options;
  std::error_code ec;
  if (!fs::is_directory(options.folder, ec))
    throw InputError(options.folder, 0, "folder to follow not found");
  if (!fs::is_regular_file(options.imu, ec))
    throw InputError(options.imu, 0, "IMU csv not found (it may be empty, but must exist)");
  impl_->calib = ReadCalibration(options.calib);
  if (options.time_offset_ns) impl_->calib.time_offset_ns = *options.time_offset_ns;
  impl_->last_new = Clock::now();
}

FolderFollower::~FolderFollower() = default;

const Calibration& FolderFollower::calibration() const {
  return impl_->calib;
}

std::optional<Measurement> FolderFollower::Next() {
  Impl& d = *impl_;
  const auto period = std::chrono::duration<double>(d.o.poll_s);
  for (;;) {
    if (!d.ready.empty()) {
      Measurement m = std::move(d.ready.front());
      d.ready.pop_front();
      return m;
    }
    if (d.end != FollowEnd::kRunning) return std::nullopt;
    if (d.o.stop && d.o.stop->load()) {
      d.end = FollowEnd::kStopped;
      continue;
    }
    const Clock::time_point now = Clock::now();
    d.Poll(now);
    if (d.end == FollowEnd::kError) {
      // A malformed IMU line: the frames the IMU read so far covers still go out.
      if (d.imu_last) d.Release(now, true, d.imu_last->t_ns);
      continue;
    }
    if (d.end != FollowEnd::kRunning) continue;
    d.Release(now, false);
    if (!d.ready.empty()) continue;
    if (SecondsSince(d.last_new, now) >= d.o.idle_s) {
      d.Release(now, true);
      d.end = FollowEnd::kIdle;
      continue;
    }
    std::this_thread::sleep_for(period);
  }
}

FollowEnd FolderFollower::end() const {
  return impl_->end;
}
const std::string& FolderFollower::message() const {
  return impl_->message;
}
int FolderFollower::frames() const {
  return impl_->frames;
}
int FolderFollower::imu_samples() const {
  return impl_->imu_given;
}
int FolderFollower::images_skipped() const {
  return impl_->skipped;
}
int FolderFollower::imu_dropped() const {
  return impl_->imu_dropped;
}
int64_t FolderFollower::t_first_ns() const {
  return impl_->t_first;
}
int64_t FolderFollower::t_last_ns() const {
  return impl_->frames > 0 ? impl_->last_frame_t : 0;
}

}  // namespace fsp
