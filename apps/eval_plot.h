// Top-view picture of an evaluation: ground truth vs aligned estimate (trajectory and objects).
// Drawing lives in apps/ (an observer of the eval library's results).
#pragma once

#include <string>

#include "fsp/eval/evaluate.h"

namespace fsp::apps {

// Writes a PNG (x-y plane, metres, north up) with the ground-truth trajectory in grey, the estimate
// after the evaluation's alignment in red, and objects (ground truth black, estimate red) when both
// object files are known. Throws InputError when the file cannot be written.
void WriteEvalTopView(const eval::Metrics& metrics, const std::string& png_path);

}  // namespace fsp::apps
