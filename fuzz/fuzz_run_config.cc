// The configuration of `fsp run` (--config FILE, apps/run_config.h): ReadRunConfig. A config that
// is read must survive ToYaml / ParseRunConfig with the same values (run_config.h: "Parsing it
// gives back the same values").
#include "fuzz_util.h"
#include "run_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace fsp;
  const auto& dir = fuzz::Scratch().Fresh();
  const std::string path = (dir / "config.yaml").string();
  fuzz::WriteFile(path, fuzz::AsText(data, size));
  apps::RunConfig config;
  if (fuzz::RejectsOrReturns("ReadRunConfig", [&] { config = apps::ReadRunConfig(path); }))
    return 0;
  const std::string yaml = apps::ToYaml(config);
  apps::RunConfig back;
  FUZZ_CHECK(!fuzz::RejectsOrReturns("ParseRunConfig(ToYaml)",
                                     [&] { back = apps::ParseRunConfig(yaml, "ToYaml"); }));
  std::string difference;
  if (!apps::SameValues(config, back, &difference)) {
    std::fprintf(stderr, "fsp fuzz: ToYaml round trip differs: %s\n", difference.c_str());
    std::abort();
  }
  return 0;
}
