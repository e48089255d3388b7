#pragma once
// The measurement behind `vlnce-sim bench`: frames per second of RGB, depth
// and RGB-D renders at NxN from random navigable poses, and agent steps per
// second, per wall-clock second and per CPU-second. A library (not a Google
// Benchmark binary) so that the app stays a thin CLI layer and the report
// keeps its own layout.

#include <cstdint>
#include <string>

#include "sim/SimConfig.h"

namespace vln::bench {

/// The options of `vlnce-sim bench`, as given on the command line.
struct SimThroughputOptions {
  std::string scene;        ///< scene file; or
  int64_t procedural = -1;  ///< procedural house seed (exactly one of both)
  int res = 256;            ///< square image size, pixels
  std::string backend = "embree";  ///< "embree", "osmesa" or "raster"
  int frames = 1000;  ///< frames per thread and pass (steps: 20x as many)
  int threads = 1;    ///< renderers (and simulators) in parallel
  int subdivide = 1;  ///< split every triangle into N x N (sim::subdivide)
  /// mesh import (up axis, scale; --scene only), navmesh and agent
  /// parameters (`vlnce-sim --config/--up-axis/--scale`)
  sim::SimConfig sim;
};

/// Loads or generates the scene, measures and prints the report to stdout;
/// returns the exit code (0). The navmesh, poses and agent steps use the
/// scene's own triangles, the renderers the subdivided ones. Throws
/// std::invalid_argument naming the option when one is out of range
/// (--res in [1, 4096], --frames >= 1, --threads in [1, 256], --subdivide
/// in [1, 64], --backend embree, osmesa or raster) or not exactly one of
/// --scene and --procedural is given, and what loading the scene throws.
int runSimThroughput(const SimThroughputOptions& options);

}  // namespace vln::bench
