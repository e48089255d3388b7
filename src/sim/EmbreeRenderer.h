#pragma once
// Private to the sim module: the Embree ray-casting backend of Renderer.
// Use createRenderer() (Renderer.h) instead of including this.

#include <memory>

#include "sim/Renderer.h"

namespace vln::sim {

/// A renderer that traces one primary ray per pixel through `rayTracer`'s
/// BVH in coherent 4x4 packets (rtcIntersect16) and shades the hit with the
/// unlit material rule of Renderer.h. `mesh` and `rayTracer` must outlive it.
/// Creation is cheap (no copy of the scene; the first colour render builds a
/// 64-byte shading record per triangle). On CPUs with AVX-512F whole packets
/// are set up and shaded at once, with AVX2 shaded in halves (HitShader,
/// Shading.h); elsewhere, or with VLN_EMBREE_SHADING=scalar set before
/// creation, portable paths compute the same bits (the same fused
/// multiply-adds in the same order), so images do not depend on the CPU.
std::unique_ptr<Renderer> createEmbreeRenderer(const TriangleMesh& mesh,
                                               const RayTracer& rayTracer);

}  // namespace vln::sim
