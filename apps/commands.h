// Subcommands of the `fsp` binary. Each Add*Command registers itself on the root app; its callback
// throws fsp::InputError on bad input (main prints one line and exits 2) and
// CLI::RuntimeError(code) for any other non-zero exit.
#pragma once

#include <CLI/CLI.hpp>

namespace fsp::apps {

void AddInfoCommand(CLI::App& root);
void AddRenderCommand(CLI::App& root);
void AddEvalCommand(CLI::App& root);
void AddDetectCommand(CLI::App& root);
void AddRunCommand(CLI::App& root);
void AddBenchCommand(CLI::App& root);
void AddConvertCommand(CLI::App& root);

}  // namespace fsp::apps
