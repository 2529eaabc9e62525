// libFuzzer target: the text pose-graph reader of dba-posegraph (`-g FILE.graph`). The bytes are
// a .graph file; it goes through the pre-scan (checkGraphText, the lines MRPT would misread
// silently), MRPT's own loadFromTextFile and the conversion to dbacov's graph (fromNetwork), as
// readGraph(path, true) does. See fuzz_target.h for the contract (here: InputError only).
#include "dbacov/mrpt/pose_graph_io.h"
#include "fuzz_scratch.h"
#include "fuzz_target.h"

extern "C" int DBACOV_FUZZ_ENTRY(const std::uint8_t* data, std::size_t size) {
  const std::string path = dbacov::fuzz::scratchFile("fuzz.graph", data, size);
  try {
    const dbacov::PoseGraph g =
        dbacov::mrpt_bridge::fromNetwork(dbacov::mrpt_bridge::readGraphMrptText(path), path);
    for (const auto& [id, T] : g.nodes)
      if (id < 0) __builtin_trap();  // ids beyond 2^31 - 1 must have been refused
  } catch (const dbacov::InputError&) {
  }
  return 0;
}
