// vlnce-sim: render one view, inspect a navmesh, or measure simulator
// throughput.
//
// Every subcommand reads its scene as the config's `sim` section says:
//   --config C.yaml   any run config; its `sim` section (mesh import,
//                     navmesh and agent parameters, renderer, RGB camera)
//   --up-axis y|z     sim.mesh.up_axis: the file's up axis
//   --scale S         sim.mesh.scale: file units to metres (0.01 for
//                     centimetres, 0.001 for millimetres)
// The flags win over the config.
//
//   vlnce-sim render --scene F --position x,y,z --heading DEG --out DIR
//       [--backend embree|osmesa|raster] [--width W --height H] [--hfov DEG]
//       [--camera-height M] [--pitch DEG]
//     writes DIR/rgb.png (8-bit RGB) and DIR/depth.png: raw z-depth as a
//     16-bit greyscale PNG in millimetres (0 = nothing hit, saturating at
//     65.535 m). --position is the agent's feet; the eye is --camera-height
//     (VLN-CE: 1.25 m) above it. Without a flag, the backend and camera
//     come from --config's sim.renderer and sim.rgb when it is given, else
//     embree, 256x256, 90 degrees, 1.25 m.
//   vlnce-sim navmesh --scene F [--map out.png] [--meters-per-pixel M]
//     prints polygon count, islands with their areas and the navigable area.
//   vlnce-sim bench (--scene F | --procedural SEED) [--res N] [--backend B]
//       [--frames K] [--threads T] [--subdivide N]
//     prints frames/s for RGB, depth and RGB-D at NxN from random navigable
//     poses, and agent steps/s; with --threads, one renderer per thread and
//     the aggregate rate. --subdivide N splits every triangle into N^2
//     (dense meshes for the large-scene target: house 1 with N = 10 has
//     645,800 triangles). The measurement is bench/sim/SimThroughput.h.

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench/sim/SimThroughput.h"
#include "common/App.h"
#include "common/Check.h"
#include "common/Config.h"
#include "sim/GeometryCheck.h"
#include "sim/MeshIo.h"
#include "sim/RayTracer.h"
#include "sim/Renderer.h"
#include "sim/Scene.h"
#include "sim/SimConfig.h"
#include "sim/TopDownMap.h"

namespace {

using namespace vln;
using namespace vln::sim;
namespace fs = std::filesystem;

// "x,y,z" -> vector; throws naming the option.
Vec3f parseVec3(const std::string& text, const char* option) {
  std::stringstream in(text);
  Vec3f v;
  char comma1 = 0;
  char comma2 = 0;
  in >> v.x() >> comma1 >> v.y() >> comma2 >> v.z();
  VLN_CHECK_ARG(in && comma1 == ',' && comma2 == ',' && (in >> std::ws).eof() &&
                    v.allFinite(),
                option, " expects x,y,z in metres, got '", text,
                "'");
  return v;
}

// ---------------------------------------------------------------------------
// the sim config every subcommand shares
// ---------------------------------------------------------------------------

struct SimOptions {
  std::string config;  // --config: a run config whose `sim` section is read
  std::string upAxis;  // --up-axis y|z, "" when not given
  float scale = 0.0f;  // --scale, 0 when not given
};

void addSimOptions(CLI::App& command, SimOptions& options) {
  command.add_option("--config", options.config,
                     "Run config whose sim section is used (YAML)");
  command
      .add_option("--up-axis", options.upAxis,
                  "Up axis of the scene file (sim.mesh.up_axis)")
      ->check(CLI::IsMember({"y", "z"}));
  command.add_option("--scale", options.scale,
                     "Scene file units to metres (sim.mesh.scale), e.g. "
                     "0.001 for millimetres");
}

// The defaults, then --config's sim section, then the flags; checked as a
// config read from YAML is.
SimConfig resolveSimConfig(const SimOptions& options, const CLI::App& command) {
  SimConfig config;
  if (!options.config.empty())
    common::readConfigFileSection(options.config, "sim", {},
                                  [&](common::ConfigVisitor& v) {
                                    v.section("sim", config, "Simulator");
                                  });
  if (!options.upAxis.empty())
    config.mesh.up_axis = options.upAxis == "z" ? UpAxis::kZ : UpAxis::kY;
  if (command.count("--scale") > 0) config.mesh.scale = options.scale;
  common::checkConfig(
      [&](common::ConfigVisitor& v) { v.section("sim", config, "Simulator"); },
      "vlnce-sim (--config, --up-axis, --scale)");
  return config;
}

// ---------------------------------------------------------------------------
// render
// ---------------------------------------------------------------------------

struct RenderArgs {
  std::string scene;
  std::string position;
  float heading = 0.0f;
  float pitch = 0.0f;
  std::string out;
  std::string backend = "embree";
  int width = 256;
  int height = 256;
  float hfov = 90.0f;
  float cameraHeight = 1.25f;
};

// Flags that were not given take the config's camera and backend when a
// config was given.
void applyConfigDefaults(const SimConfig& config, const CLI::App& command,
                         RenderArgs& args) {
  if (command.count("--config") == 0) return;
  if (command.count("--backend") == 0)
    args.backend = std::string(rendererBackendName(config.renderer));
  if (command.count("--width") == 0) args.width = config.rgb.width;
  if (command.count("--height") == 0) args.height = config.rgb.height;
  if (command.count("--hfov") == 0) args.hfov = config.rgb.hfov;
  if (command.count("--camera-height") == 0)
    args.cameraHeight = config.rgb.position_y;
}

int runRender(const RenderArgs& args, const SimConfig& config) {
  const Vec3f feet = parseVec3(args.position, "--position");
  VLN_CHECK_ARG(args.width >= 1 && args.height >= 1 && args.width <= 8192 &&
                    args.height <= 8192,
                "render: --width/--height must be in [1, 8192], got ",
                args.width, "x", args.height);
  VLN_CHECK_ARG(std::isfinite(args.heading) && std::isfinite(args.pitch) &&
                    std::isfinite(args.cameraHeight),
                "render: --heading, --pitch and --camera-height must be "
                "finite, got ",
                args.heading, ", ", args.pitch, ", ", args.cameraHeight);
  // rendering needs the triangles only: no navmesh build
  const LoadedScene loaded = loadScene(args.scene, config.mesh);
  const RayTracer tracer(loaded.mesh);
  auto renderer = createRenderer(
      loaded.mesh, tracer, parseRendererBackend(args.backend, "--backend"));
  // the renderer refuses an eye far outside the scene; say it in the
  // flags' terms
  const Eigen::AlignedBox3f bounds = loaded.mesh.bounds();
  const Vec3f eye = feet + Vec3f(0.0f, args.cameraHeight, 0.0f);
  VLN_CHECK_ARG(poseBounds(bounds).contains(eye), "render: --position ",
                args.position, " puts the eye at (", eye.transpose(),
                "), outside the scene (bounds [", bounds.min().transpose(),
                "] to [", bounds.max().transpose(), "] plus ", kPoseMargin,
                " m)");
  const CameraPose pose{eye, degToRad(args.heading), degToRad(args.pitch)};
  const CameraIntrinsics camera{args.width, args.height, args.hfov};
  const size_t pixels = static_cast<size_t>(args.width) * args.height;
  std::vector<uint8_t> rgb(pixels * 3);
  std::vector<float> depth(pixels);
  renderer->renderRgbDepth(pose, camera, rgb, depth);
  const fs::path out(args.out);
  saveRgbPng(out / "rgb.png", args.width, args.height, rgb);
  saveDepthPng(out / "depth.png", args.width, args.height, depth);
  size_t hits = 0;
  for (float d : depth) hits += d > 0.0f ? 1 : 0;
  std::printf("wrote %s and %s (%dx%d, %s, %.1f%% of pixels hit)\n",
              (out / "rgb.png").c_str(), (out / "depth.png").c_str(),
              args.width, args.height, args.backend.c_str(),
              100.0 * static_cast<double>(hits) / static_cast<double>(pixels));
  return 0;
}

// ---------------------------------------------------------------------------
// navmesh
// ---------------------------------------------------------------------------

struct NavMeshArgs {
  std::string scene;
  std::string map;
  float metersPerPixel = 0.05f;
  bool noCache = false;
};

int runNavMesh(const NavMeshArgs& args, SimConfig config) {
  config.cache_navmesh = config.cache_navmesh && !args.noCache;
  const auto scene = Scene::load(args.scene, config);
  const NavMesh& navmesh = scene->navmesh();
  std::printf("scene: %s (%zu triangles)\n", scene->name().c_str(),
              scene->mesh().triangleCount());
  std::printf("polygons: %d\n", navmesh.polygonCount());
  std::printf("islands: %d\n", navmesh.islandCount());
  for (int i = 0; i < navmesh.islandCount(); ++i)
    std::printf("  island %d: %.2f m^2\n", i, navmesh.islandArea(i));
  std::printf("navigable area: %.2f m^2\n", navmesh.navigableArea());
  if (!args.map.empty()) {
    // the map shows the floor of the largest island
    std::mt19937_64 rng(0);
    const Vec3f onFloor = navmesh.randomPoint(rng, /*island=*/0);
    TopDownMap map(*scene, args.metersPerPixel, onFloor.y());
    map.save(args.map);
    std::printf("map: %s (%dx%d)\n", args.map.c_str(), map.width(), map.height());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return vln::common::runMain("vlnce-sim", [&] {
    CLI::App app{"vlnce-sim: render views, inspect navmeshes, measure throughput"};
    app.require_subcommand(1);
    common::initLogging();

    RenderArgs render;
    auto* renderCmd = app.add_subcommand("render", "Render RGB and depth PNGs of one view");
    renderCmd->add_option("--scene", render.scene, "Scene file (.glb, .obj, .ply)")->required();
    renderCmd->add_option("--position", render.position, "Agent feet x,y,z (m)")->required();
    renderCmd->add_option("--heading", render.heading, "Heading (degrees, 0 = -Z, left positive)")->required();
    renderCmd->add_option("--pitch", render.pitch, "Camera pitch (degrees, up positive)");
    renderCmd->add_option("--out", render.out, "Output directory")->required();
    renderCmd->add_option("--backend", render.backend,
                          "embree, osmesa or raster");
    renderCmd->add_option("--width", render.width, "Image width (pixels)");
    renderCmd->add_option("--height", render.height, "Image height (pixels)");
    renderCmd->add_option("--hfov", render.hfov, "Horizontal field of view (degrees)");
    renderCmd->add_option("--camera-height", render.cameraHeight, "Eye height above the feet (m)");
    SimOptions renderSim;
    addSimOptions(*renderCmd, renderSim);

    NavMeshArgs navmesh;
    auto* navmeshCmd = app.add_subcommand("navmesh", "Build or load a navmesh and describe it");
    navmeshCmd->add_option("--scene", navmesh.scene, "Scene file")->required();
    navmeshCmd->add_option("--map", navmesh.map, "Write a top-down map PNG here");
    navmeshCmd->add_option("--meters-per-pixel", navmesh.metersPerPixel, "Map scale");
    navmeshCmd->add_flag("--no-cache", navmesh.noCache, "Do not read or write <scene>.navmesh");
    SimOptions navmeshSim;
    addSimOptions(*navmeshCmd, navmeshSim);

    bench::SimThroughputOptions throughput;
    auto* benchCmd = app.add_subcommand("bench", "Measure rendering and stepping throughput");
    auto* sceneOpt =
        benchCmd->add_option("--scene", throughput.scene, "Scene file");
    auto* proceduralOpt = benchCmd->add_option(
        "--procedural", throughput.procedural, "Procedural house seed");
    sceneOpt->excludes(proceduralOpt);
    benchCmd->add_option("--res", throughput.res, "Square image size (pixels)");
    benchCmd->add_option("--backend", throughput.backend,
                         "embree, osmesa or raster");
    benchCmd->add_option("--frames", throughput.frames,
                         "Frames per thread and pass");
    benchCmd->add_option("--threads", throughput.threads,
                         "Renderers in parallel, one per thread");
    benchCmd->add_option("--subdivide", throughput.subdivide,
                         "Split every triangle into N x N (edges cut in N)");
    SimOptions benchSim;
    addSimOptions(*benchCmd, benchSim);

    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return app.exit(e);
    }
    if (*renderCmd) {
      const SimConfig config = resolveSimConfig(renderSim, *renderCmd);
      applyConfigDefaults(config, *renderCmd, render);
      return runRender(render, config);
    }
    if (*navmeshCmd)
      return runNavMesh(navmesh, resolveSimConfig(navmeshSim, *navmeshCmd));
    throughput.sim = resolveSimConfig(benchSim, *benchCmd);
    if (benchCmd->count("--config") > 0 && benchCmd->count("--backend") == 0)
      throughput.backend =
          std::string(rendererBackendName(throughput.sim.renderer));
    return bench::runSimThroughput(throughput);
  });
}
