// The pose-graph fuzz target as an ordinary function, for test_fuzz_replay.cpp.
#define DBACOV_FUZZ_ENTRY dbacovFuzzGraph
#include "fuzz_graph.cpp"
