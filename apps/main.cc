// fsp: monocular visual-inertial SLAM with rectangles as Framed Structural Points.
#include <cstdio>
#include <exception>

#include <glog/logging.h>
#include <CLI/CLI.hpp>

#include "commands.h"
#include "fsp/common/error.h"

int main(int argc, char** argv) {
  // Ceres logs through glog; its warnings (e.g. a rank-deficient covariance, reported in map.json
  // as sigma -1) are not for users. Errors still show.
  FLAGS_minloglevel = google::GLOG_ERROR;
  FLAGS_logtostderr = true;
  google::InitGoogleLogging(argv[0]);
  CLI::App app{
      "FSP-SLAM: monocular visual-inertial SLAM whose landmarks are rectangles (doors, windows,\n"
      "cabinets, posters, AprilTags) represented as Framed Structural Points.\n"
      "Run `fsp SUBCOMMAND --help` for the options of each subcommand."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "fsp 0.1.0");
  fsp::apps::AddInfoCommand(app);
  fsp::apps::AddRenderCommand(app);
  fsp::apps::AddEvalCommand(app);
  fsp::apps::AddDetectCommand(app);
  fsp::apps::AddRunCommand(app);
  fsp::apps::AddBenchCommand(app);
  fsp::apps::AddConvertCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const fsp::InputError& e) {
    std::fprintf(stderr, "fsp: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fsp: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
