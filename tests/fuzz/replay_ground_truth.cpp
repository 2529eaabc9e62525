// The ground-truth fuzz target as an ordinary function, for test_fuzz_replay.cpp.
#define DBACOV_FUZZ_ENTRY dbacovFuzzGroundTruth
#include "fuzz_ground_truth.cpp"
