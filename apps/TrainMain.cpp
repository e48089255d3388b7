// train: imitation learning of a VLN-CE policy (see src/train/TrainCommand.h).
#include <CLI/CLI.hpp>

#include <iostream>

#include "common/App.h"
#include "train/TrainCommand.h"

int main(int argc, char** argv) {
  vln::common::pinNumericalRuntime("train", argv);
  return vln::common::runMain("train", [&] {
    CLI::App app{"Train a VLN-CE policy (teacher forcing or DAgger)"};
    vln::train::TrainOptions options;
    app.add_option("--config", options.config, "Run config YAML")->required();
    app.add_option("--set", options.overrides,
                   "Override: section.key=value (repeatable)");
    app.add_flag("--dry-run", options.dry_run,
                 "Print the resolved config and exit");
    app.add_flag("--resume", options.resume, "Continue the run in output.dir");
    app.add_option("--export", options.export_path,
                   "After training, export the best checkpoint as TorchScript");
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& error) {
      return app.exit(error);
    }
    return vln::train::runTrain(options, std::cout);
  });
}
