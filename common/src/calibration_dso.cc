// DSO / TUM-VI / DM-VIO camera.txt (format in calibration.h, ReadDsoCamera).
#include <cctype>
#include <string>
#include <vector>

#include "fsp/common/calibration.h"
#include "fsp/common/csv.h"
#include "fsp/common/error.h"

namespace fsp {

namespace {

const char* const kParamNames[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"};

// A model named on line 1 and how many numbers follow its name.
struct DsoModel {
  const char* name;
  size_t params;
  bool supported;
  const char* kind;  // for the rejection message
};

const DsoModel kModels[] = {
    {"Pinhole", 5, true, "pinhole"},
    {"RadTan", 8, true, "radial-tangential"},
    {"FOV", 5, true, "ATAN"},
    {"EquiDistant", 8, false, "fisheye"},
    {"KannalaBrandt", 8, false, "fisheye"},
};

[[noreturn]] void Unsupported(const TableReader& reader, const std::string& model,
                              const std::string& kind) {
  reader.Fail("unsupported camera model '" + model + "' (" + kind +
              "): fsp supports pinhole cameras with radial-tangential (radtan) distortion only");
}

}  // namespace

PinholeRadtan ReadDsoCamera(const std::string& path) {
  TableReader reader(path, "DSO camera.txt");
  std::vector<std::string> f;
  if (!reader.NextRow(&f)) {
    throw InputError(path, 0,
                     "camera.txt is empty (expected 'Pinhole fx fy cx cy 0' or 'RadTan fx fy cx cy "
                     "k1 k2 p1 p2', then 'width height')");
  }
  const int model_line = reader.line();
  // Line 1: an optional model name, then its numbers.
  std::string model;
  std::vector<std::string> numbers = f;
  if (!f[0].empty() && std::isalpha(static_cast<unsigned char>(f[0][0]))) {
    model = f[0];
    numbers.erase(numbers.begin());
    const DsoModel* known = nullptr;
    for (const DsoModel& m : kModels)
      if (model == m.name) known = &m;
    if (known == nullptr) {
      reader.Fail(
          "unknown camera model '" + model +
          "': expected Pinhole, RadTan, FOV, EquiDistant or KannalaBrandt (DSO camera.txt)");
    }
    if (!known->supported) Unsupported(reader, model, known->kind);
    if (numbers.size() != known->params) {
      reader.Fail("'" + model + "' needs " + std::to_string(known->params) + " numbers (" +
                  (known->params == 5 ? "fx fy cx cy 0" : "fx fy cx cy k1 k2 p1 p2") + "), found " +
                  std::to_string(numbers.size()));
    }
  } else if (numbers.size() != 5 && numbers.size() != 8) {
    reader.Fail(
        "expected 5 numbers (pinhole: fx fy cx cy 0) or 8 (radtan: fx fy cx cy k1 k2 p1 p2) "
        "on the camera line, found " +
        std::to_string(numbers.size()));
  }
  // The fields keep their column numbers in messages (the model name is column 1).
  const size_t first = model.empty() ? 0 : 1;
  std::vector<double> p;
  for (size_t i = 0; i < numbers.size(); ++i) {
    const char* name = numbers.size() == 5 && i == 4 ? "omega" : kParamNames[i];
    p.push_back(reader.Double(f, first + i, name));
  }
  // Five numbers without a name, or named FOV: DSO's FOV (ATAN) model unless the fifth (omega) is
  // 0, a pinhole. A named Pinhole ignores the fifth, as DSO does.
  if ((model.empty() || model == "FOV") && numbers.size() == 5 && p[4] != 0.0) {
    Unsupported(reader, "FOV", "ATAN with omega " + numbers[4] + "; 0 would be a pinhole");
  }

  // Line 2: the image size.
  if (!reader.NextRow(&f)) {
    throw InputError(path, 0, "missing the image size line 'width height' after the camera line");
  }
  reader.ExpectColumns(f, 2, 2);
  const int64_t w = reader.Int64(f, 0, "width");
  const int64_t h = reader.Int64(f, 1, "height");
  if (w <= 0 || h <= 0 || w > 100000 || h > 100000) {
    reader.Fail("image size " + std::to_string(w) + "x" + std::to_string(h) + " is not plausible");
  }
  // Lines 3-4 (DSO's rectified output: crop / full / none / K, and its size) are not read.

  PinholeRadtan cam;
  cam.width = static_cast<int>(w);
  cam.height = static_cast<int>(h);
  cam.fx = p[0];
  cam.fy = p[1];
  cam.cx = p[2];
  cam.cy = p[3];
  if (cam.cx < 1.0 && cam.cy < 1.0) {
    // DSO's relative form: fractions of the image size with the origin at the top-left pixel's
    // outer corner; -0.5 moves it to that pixel's centre (the OpenCV convention used here).
    cam.fx *= w;
    cam.fy *= h;
    cam.cx = cam.cx * static_cast<double>(w) - 0.5;
    cam.cy = cam.cy * static_cast<double>(h) - 0.5;
  }
  if (p.size() == 8)
    for (size_t i = 0; i < 4; ++i) cam.distortion[i] = p[4 + i];
  std::string why;
  if (!cam.Check(&why)) throw InputError(path, model_line, "camera: " + why);
  return cam;
}

}  // namespace fsp
