#pragma once
// Private to the sim module: the rasterising backend of Renderer. Use
// createRenderer() (Renderer.h) instead of including this.

#include <memory>

#include "sim/Renderer.h"

namespace vln::sim {

/// A renderer that rasterises `mesh` on the CPU into a visibility buffer
/// (nearest triangle per pixel centre) and shades each visible pixel once
/// with the unlit material rule of Renderer.h. Coverage is the ray caster's:
/// a pixel is covered when the ray through its centre (pixelDirection())
/// passes through the triangle in front of the eye, decided with the
/// triangle's three edge planes through the eye, so there is no near plane
/// and a shared edge leaves neither gaps nor double hits. Depth and
/// barycentrics follow from the same planes. It therefore renders what the
/// Embree backend renders up to float rounding (tested), for a fraction of
/// the work on scenes of a few thousand triangles: triangles are drawn near
/// to far, and one that lies behind everything already drawn in each 8x8
/// tile it overlaps is skipped whole. The colour and depth cameras of one
/// view share the triangles' set-up. Rasterising uses only IEEE additions,
/// multiplications, divisions and comparisons, none fused, and shading is
/// the Embree backend's rule (Shading.h), so every CPU renders the same
/// bits. `mesh` must outlive the renderer.
std::unique_ptr<Renderer> createRasterRenderer(const TriangleMesh& mesh);

}  // namespace vln::sim
