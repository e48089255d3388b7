// vlnce-export: a training checkpoint as a self-contained TorchScript policy
// (see src/train/TrainCommand.h and src/models/Export.h).
#include <CLI/CLI.hpp>

#include <iostream>

#include "common/App.h"
#include "train/TrainCommand.h"

int main(int argc, char** argv) {
  vln::common::pinNumericalRuntime("vlnce-export", argv);
  return vln::common::runMain("vlnce-export", [&] {
    CLI::App app{"Export a checkpoint (policy + encoders) as TorchScript"};
    vln::train::ExportOptions options;
    app.add_option("--checkpoint", options.checkpoint, "ckpt.<i>.pth")
        ->required();
    app.add_option("--config", options.config,
                   "Run config (default: the config stored in the checkpoint)");
    app.add_option("--out", options.out, "Output TorchScript file")->required();
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& error) {
      return app.exit(error);
    }
    return vln::train::runExport(options, std::cout);
  });
}
