// Frames stored as image files: listed in a data.csv or a DSO times.txt, or named by their
// timestamps.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>

#include <opencv2/imgcodecs.hpp>

#include "dataset_internal.h"
#include "fsp/common/error.h"

namespace fsp::internal {

namespace fs = std::filesystem;

namespace {

class ImageFileDecoder : public FrameDecoder {
 public:
  explicit ImageFileDecoder(std::vector<std::string> paths) : paths_(std::move(paths)) {}
  std::string Name(int index) const override { return paths_.at(static_cast<size_t>(index)); }
  cv::Mat Decode(int index) override { return ReadGreyImage(Name(index)); }

 private:
  std::vector<std::string> paths_;
};

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool IsImageExtension(const std::string& ext) {
  static const std::set<std::string> kExt = {".png", ".jpg", ".jpeg", ".pgm", ".bmp"};
  return kExt.count(Lower(ext)) > 0;
}

// T_S (decimal seconds, "1650458716.848713") in nanoseconds, exactly (rounded beyond 9 decimals);
// false unless it is plain digits with at most one '.' and fits.
bool DecimalSecondsToNs(const std::string& t_s, int64_t* t_ns) {
  const size_t dot = t_s.find('.');
  const std::string whole = t_s.substr(0, dot);
  const std::string frac = dot == std::string::npos ? std::string() : t_s.substr(dot + 1);
  const auto digits = [](const std::string& s) {
    return std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
  };
  if ((whole.empty() && frac.empty()) || !digits(whole) || !digits(frac) || whole.size() > 10)
    return false;
  const int64_t seconds = whole.empty() ? 0 : std::stoll(whole);
  if (seconds > 9'000'000'000LL) return false;  // beyond int64 nanoseconds (year 2255)
  int64_t ns = seconds * 1'000'000'000LL;
  int64_t scale = 100'000'000;
  for (size_t i = 0; i < frac.size() && i < 9; ++i, scale /= 10) ns += (frac[i] - '0') * scale;
  if (frac.size() > 9 && frac[9] >= '5') ++ns;
  *t_ns = ns;
  return true;
}

}  // namespace

cv::Mat ReadGreyImage(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, 0, "image not found");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open image");
  // One read of the whole file (a byte-wise stream iterator cost a tenth of a PNG's decoding).
  in.seekg(0, std::ios::end);
  std::vector<uchar> bytes(static_cast<size_t>(std::max<std::streamoff>(0, in.tellg())));
  in.seekg(0, std::ios::beg);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!in) throw InputError(path, 0, "cannot read image");
  if (bytes.empty()) throw InputError(path, 0, "image file is empty");
  cv::Mat image;
  std::string cv_error;
  const std::string printed = CaptureStderr([&] {
    try {
      // IMREAD_GRAYSCALE also reduces 16-bit images to 8 bits.
      image = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
    } catch (const cv::Exception& e) {
      cv_error = e.err;
    }
  });
  if (image.empty()) {
    const std::string detail = !printed.empty()    ? FirstLineDetail(printed)
                               : !cv_error.empty() ? FirstLineDetail(cv_error)
                                                   : std::string(" (corrupt or not an image file)");
    throw InputError(path, 0, "image does not decode" + detail);
  }
  // libjpeg fills a truncated file with grey and only warns: that is not the recorded image.
  if (printed.find("Premature end of JPEG") != std::string::npos) {
    throw InputError(path, 0, "image is truncated" + FirstLineDetail(printed));
  }
  if (image.type() != CV_8UC1) {
    cv::Mat grey;
    image.convertTo(grey, CV_8U);
    image = grey;
  }
  return image;
}

FrameList ListImagesFromCsv(const std::string& csv_path, const std::string& image_dir) {
  TableReader reader(csv_path, "image list");
  FrameList list;
  std::vector<std::string> paths;
  std::vector<std::string> f;
  int prev_line = 0;
  while (reader.NextRow(&f)) {
    reader.ExpectColumns(f, 2, 2);
    const int64_t t = reader.Int64(f, 0, "t_ns");
    if (!list.t_ns.empty()) CheckIncreasing(reader, t, list.t_ns.back(), prev_line);
    prev_line = reader.line();
    if (f[1].empty()) reader.Fail("column 2 (filename) is empty");
    const std::string path = (fs::path(image_dir) / f[1]).string();
    std::error_code ec;
    if (!fs::is_regular_file(path, ec))
      reader.Fail("image '" + f[1] + "' not found (" + path + ")");
    list.t_ns.push_back(t);
    paths.push_back(path);
  }
  if (list.t_ns.empty())
    throw InputError(csv_path, 0, "no frames listed (expected rows t_ns,filename)");
  list.decoder = std::make_unique<ImageFileDecoder>(std::move(paths));
  return list;
}

FrameList ListImagesFromDsoTimes(const std::string& times_path, const std::string& image_dir) {
  TableReader reader(times_path, "DSO times.txt");
  FrameList list;
  std::vector<std::string> paths;
  std::vector<std::string> f;
  int prev_line = 0;
  while (reader.NextRow(&f)) {
    reader.ExpectColumns(f, 2, 3);
    const std::string& id = f[0];
    int64_t t = 0;
    if (!DecimalSecondsToNs(f[1], &t)) {
      const double s = reader.Double(f, 1, "t_s");
      if (!(s >= 0.0 && s < 9.2e9)) reader.Fail("column 2 (t_s) is not a time in seconds: " + f[1]);
      t = std::llround(s * 1e9);
    }
    if (f.size() == 3) reader.Double(f, 2, "exposure_ms");
    // An id that is the same time in nanoseconds is exact where t_s was rounded.
    if (id.size() >= 10 && id.size() <= 19 &&
        std::all_of(id.begin(), id.end(), [](unsigned char c) { return std::isdigit(c); })) {
      errno = 0;
      const long long id_ns = std::strtoll(id.c_str(), nullptr, 10);
      if (errno != ERANGE && std::llabs(id_ns - t) <= 1'000'000) t = id_ns;
    }
    if (!list.t_ns.empty()) CheckIncreasing(reader, t, list.t_ns.back(), prev_line);
    prev_line = reader.line();
    std::string path;
    for (const char* ext : {".png", ".jpg", ".jpeg", ".pgm", ".bmp"}) {
      const fs::path candidate = fs::path(image_dir) / (id + ext);
      std::error_code ec;
      if (fs::is_regular_file(candidate, ec)) {
        path = candidate.string();
        break;
      }
    }
    if (path.empty()) {
      reader.Fail("no image '" + id + ".png' or '" + id + ".jpg' (or .jpeg/.pgm/.bmp) in " +
                  image_dir);
    }
    list.t_ns.push_back(t);
    paths.push_back(path);
  }
  if (list.t_ns.empty()) {
    throw InputError(times_path, 0, "no frames listed (expected rows 'id t_s [exposure_ms]')");
  }
  list.decoder = std::make_unique<ImageFileDecoder>(std::move(paths));
  return list;
}

FrameList ListImagesByName(const std::string& folder) {
  struct Entry {
    int64_t t;
    std::string path;
  };
  std::vector<Entry> entries;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(folder, ec)) {
    if (!e.is_regular_file(ec) || !IsImageExtension(e.path().extension().string())) continue;
    const std::string stem = e.path().stem().string();
    errno = 0;
    const long long t = std::strtoll(stem.c_str(), nullptr, 10);
    const bool digits =
        !stem.empty() && errno != ERANGE &&
        std::all_of(stem.begin(), stem.end(), [](unsigned char c) { return std::isdigit(c); });
    if (!digits) {
      throw InputError(
          e.path().string(), 0,
          "image file name is not a nanosecond timestamp: name images <t_ns>.png or list them in " +
              (fs::path(folder) / "data.csv").string());
    }
    entries.push_back({static_cast<int64_t>(t), e.path().string()});
  }
  if (ec) throw InputError(folder, 0, "cannot list folder: " + ec.message());
  if (entries.empty()) {
    throw InputError(
        folder, 0,
        "no images found (expected files named <t_ns>.png/.jpg/.pgm/.bmp or a data.csv)");
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.t != b.t ? a.t < b.t : a.path < b.path;
  });
  FrameList list;
  std::vector<std::string> paths;
  for (size_t i = 0; i < entries.size(); ++i) {
    if (i > 0 && entries[i].t == entries[i - 1].t) {
      throw InputError(folder, 0,
                       "duplicate timestamp " + std::to_string(entries[i].t) + ": " +
                           entries[i - 1].path + " and " + entries[i].path);
    }
    list.t_ns.push_back(entries[i].t);
    paths.push_back(entries[i].path);
  }
  list.decoder = std::make_unique<ImageFileDecoder>(std::move(paths));
  return list;
}

}  // namespace fsp::internal
