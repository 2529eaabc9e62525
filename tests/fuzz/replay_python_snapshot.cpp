// The Python Snapshot fuzz target as an ordinary function, for test_fuzz_replay.cpp.
#define DBACOV_FUZZ_ENTRY dbacovFuzzPythonSnapshot
#include "fuzz_python_snapshot.cpp"
