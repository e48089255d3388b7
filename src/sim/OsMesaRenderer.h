#pragma once
// Private to the sim module: the OSMesa (llvmpipe) rasterising backend of
// Renderer. Use createRenderer() (Renderer.h) instead of including this.

#include <memory>

#include "sim/Renderer.h"

namespace vln::sim {

/// A renderer with its own offscreen OSMesa context, into which `mesh` is
/// uploaded once (vertex and index buffers, textures, per-triangle object
/// ids). The context is made current on the calling thread for each render
/// and released after it, so the renderer may move between threads but must
/// never be used by two at once. All OSMesa renderers of the process render
/// one at a time (a process-wide lock): llvmpipe in Mesa 22.3 crashes when
/// contexts render on two threads at once. llvmpipe reads LP_NUM_THREADS
/// from the environment when the first context is created (rasteriser
/// threads; 0 = rasterise on the calling thread); this code never sets it.
/// Throws std::runtime_error when no suitable context (OpenGL 3.3 core with
/// clip control) can be created.
std::unique_ptr<Renderer> createOsMesaRenderer(const TriangleMesh& mesh);

}  // namespace vln::sim
