// The .npz fuzz target as an ordinary function, for test_fuzz_replay.cpp.
#define DBACOV_FUZZ_ENTRY dbacovFuzzNpz
#include "fuzz_npz.cpp"
