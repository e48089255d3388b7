// The navigability check of furniture placement (HouseBuilderFurniture.cpp):
// a grid search over one room.

// First of all includes: no FMA contraction (see the header).
#include "world/HouseFpContract.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "world/HouseBuilder.h"

namespace vln::world::house {
namespace {

using Box2 = Eigen::AlignedBox2f;
using Box3 = Eigen::AlignedBox3f;

// Half the narrowest corridor kept free, metres (corridors >= 0.6 m).
constexpr float kAgentClearance = 0.3f;
// How close (beyond the clearance) a reachable spot must get to an object.
constexpr float kReachSlack = 0.25f;
// The same for objects hung on walls, which may hang above furniture.
constexpr float kHungReach = 1.5f;

float distanceToBox(const Vec2f& p, const Box2& box) {
  const float dx =
      std::max({box.min().x() - p.x(), 0.0f, p.x() - box.max().x()});
  const float dz =
      std::max({box.min().y() - p.y(), 0.0f, p.y() - box.max().y()});
  return std::sqrt(dx * dx + dz * dz);
}

// objects an agent cannot walk through (rugs are walked on)
bool blocksWalking(const Box3& box) {
  return box.max().y() > 0.05f && box.min().y() < 1.5f;
}

}  // namespace

bool roomStaysNavigable(const Box2& interior, const std::vector<Vec2f>& doors,
                        const std::vector<Box3>& placed,
                        const std::vector<Box2>& extra) {
  const int nx = static_cast<int>(interior.sizes().x() / kGridCell);
  const int nz = static_cast<int>(interior.sizes().y() / kGridCell);
  if (nx <= 0 || nz <= 0) return false;
  const float ox = interior.min().x(), oz = interior.min().y();
  auto cellCenter = [&](int i, int k) {
    return Vec2f(ox + (static_cast<float>(i) + 0.5f) * kGridCell,
                 oz + (static_cast<float>(k) + 0.5f) * kGridCell);
  };
  // cells whose centres may lie within `reach` of `box`
  auto cellRange = [&](const Box2& box, float reach, int& i0, int& i1, int& k0,
                       int& k1) {
    i0 = std::max(
        0, static_cast<int>((box.min().x() - reach - ox) / kGridCell) - 1);
    i1 = std::min(
        nx - 1, static_cast<int>((box.max().x() + reach - ox) / kGridCell) + 1);
    k0 = std::max(
        0, static_cast<int>((box.min().y() - reach - oz) / kGridCell) - 1);
    k1 = std::min(
        nz - 1, static_cast<int>((box.max().y() + reach - oz) / kGridCell) + 1);
  };

  // walls, then each obstacle over the cells near it
  std::vector<uint8_t> free(static_cast<size_t>(nx) * nz, 0);
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < nx; ++i) {
      const Vec2f p = cellCenter(i, k);
      const float toWall = std::min({p.x() - ox, interior.max().x() - p.x(),
                                     p.y() - oz, interior.max().y() - p.y()});
      free[static_cast<size_t>(k) * nx + i] = toWall >= kAgentClearance;
    }
  auto block = [&](const Box2& box) {
    int i0, i1, k0, k1;
    cellRange(box, kAgentClearance, i0, i1, k0, k1);
    for (int k = k0; k <= k1; ++k)
      for (int i = i0; i <= i1; ++i)
        if (distanceToBox(cellCenter(i, k), box) < kAgentClearance)
          free[static_cast<size_t>(k) * nx + i] = 0;
  };
  for (const Box2& box : extra) block(box);
  for (const Box3& box : placed)
    if (blocksWalking(box)) block(footprint(box));

  auto cellOf = [&](const Vec2f& p) {
    const int i =
        std::clamp(static_cast<int>((p.x() - ox) / kGridCell), 0, nx - 1);
    const int k =
        std::clamp(static_cast<int>((p.y() - oz) / kGridCell), 0, nz - 1);
    return static_cast<size_t>(k) * nx + i;
  };
  // flood fill from the first doorway
  std::vector<uint8_t> reached(free.size(), 0);
  const size_t start = cellOf(doors.front());
  if (!free[start]) return false;
  std::vector<size_t> stack{start};
  reached[start] = 1;
  while (!stack.empty()) {
    const size_t c = stack.back();
    stack.pop_back();
    const int i = static_cast<int>(c % nx), k = static_cast<int>(c / nx);
    const int di[4] = {1, -1, 0, 0}, dk[4] = {0, 0, 1, -1};
    for (int n = 0; n < 4; ++n) {
      const int ii = i + di[n], kk = k + dk[n];
      if (ii < 0 || kk < 0 || ii >= nx || kk >= nz) continue;
      const size_t nc = static_cast<size_t>(kk) * nx + ii;
      if (free[nc] && !reached[nc]) {
        reached[nc] = 1;
        stack.push_back(nc);
      }
    }
  }
  for (const Vec2f& seed : doors)
    if (!reached[cellOf(seed)]) return false;
  // every object (rugs included) has a reachable spot beside it; things
  // hung on walls may be seen from a little further (over a sofa, say)
  for (const Box3& box : placed) {
    const Box2 fp = footprint(box);
    const float reach =
        kAgentClearance + (box.min().y() > 0.8f ? kHungReach : kReachSlack);
    int i0, i1, k0, k1;
    cellRange(fp, reach, i0, i1, k0, k1);
    bool near = false;
    for (int k = k0; k <= k1 && !near; ++k)
      for (int i = i0; i <= i1 && !near; ++i)
        near = reached[static_cast<size_t>(k) * nx + i] &&
               distanceToBox(cellCenter(i, k), fp) <= reach;
    if (!near) return false;
  }
  return true;
}

}  // namespace vln::world::house
