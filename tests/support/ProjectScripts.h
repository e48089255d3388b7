#pragma once
// Running the project's Python scripts (scripts/*.py) from tests, the way a
// user runs them: /usr/bin/python3 on the source tree's file, output and
// exit status captured. Tests of scripts skip when python3 is missing.
#include <string>

#include "support/TestPaths.h"

namespace vln::test {

/// True when /usr/bin/python3 runs (checked once).
inline bool havePython() {
  static const bool have =
      runCommand("/usr/bin/python3 -c 'import json' 2>&1") == 0;
  return have;
}

/// Runs scripts/<script> with `args` (shell words); returns its exit status
/// with stdout and stderr in `log`.
inline int runProjectScript(const std::string& script, const std::string& args,
                            std::string* log) {
  const auto path = sourcePath() / "scripts" / script;
  return runCommand("/usr/bin/python3 " + path.string() + " " + args + " 2>&1",
                    log);
}

}  // namespace vln::test
