// Fuzzes the nav-graph reader (data::readNavGraph) and, on graphs it
// accepts, the queries a loaded graph must answer without faults.
#include "data/NavGraph.h"
#include "FuzzUtil.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto file = vln::fuzz::writeInput("graph.json", data, size);
  vln::fuzz::expectDocumentedErrors([&] {
    vln::data::NavGraph graph = vln::data::readNavGraph(file);
    if (graph.numNodes() > 0) {
      int last = graph.numNodes() - 1;
      (void)graph.shortestPath(0, last);
      (void)graph.nearestNode(graph.node(last).position);
    }
  });
  return 0;
}
