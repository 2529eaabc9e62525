// The rawlog fuzz target as an ordinary function, for test_fuzz_replay.cpp.
#define DBACOV_FUZZ_ENTRY dbacovFuzzRawlog
#include "fuzz_rawlog.cpp"
