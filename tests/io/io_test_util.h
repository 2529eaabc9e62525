// Helpers for the dbacov_io tests: temporary directories, NumPy as an independent reference
// (the system python), file bytes, and checks on error messages.
#pragma once

#include <stdlib.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dbacov/core/errors.h"
#include "dbacov/io/npy.h"
#include "largest_allocation.h"
#include "temp_dir.h"

#ifndef DBACOV_PYTHON
#define DBACOV_PYTHON "/usr/bin/python3"
#endif

namespace dbacov::io::testing {

using TempDir = ::dbacov::testing::TempDir;

/// True if the system python imports numpy (checked once).
inline bool haveNumpy() {
  static const bool ok = std::system(DBACOV_PYTHON " -c 'import numpy' >/dev/null 2>&1") == 0;
  return ok;
}

#define DBACOV_REQUIRE_NUMPY()                                                           \
  do {                                                                                   \
    if (!::dbacov::io::testing::haveNumpy())                                             \
      GTEST_SKIP() << "needs " DBACOV_PYTHON " with numpy (python3-numpy) as reference"; \
  } while (0)

/// Runs `script` with the system python in `dir` (as cwd; prints go to the test log). Returns the
/// exit code (-1 if it did not exit normally).
inline int runPython(const TempDir& dir, const std::string& script) {
  static int counter = 0;
  const std::string path = dir.file("script_" + std::to_string(counter++) + ".py");
  std::ofstream(path) << "import numpy as np\nimport os, sys, zipfile, struct\nos.chdir(" << '"'
                      << dir.path() << '"' << ")\n"
                      << script << "\n";
  const int status = std::system((std::string(DBACOV_PYTHON) + " " + path).c_str());
  std::filesystem::remove(path);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

inline std::vector<unsigned char> readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), {});
}
inline void writeBytes(const std::string& path, const std::vector<unsigned char>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}
inline std::string readText(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// Runs `f`, expects a dbacov::InputError, and returns its message ("" plus a failure otherwise).
template <typename F>
std::string inputErrorOf(F&& f) {
  try {
    f();
  } catch (const dbacov::InputError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected dbacov::InputError, got another exception: " << e.what();
    return "";
  }
  ADD_FAILURE() << "expected dbacov::InputError, nothing was thrown";
  return "";
}

/// Expects every one of `parts` in `message`.
inline void expectMentions(const std::string& message, std::initializer_list<std::string> parts) {
  for (const std::string& p : parts)
    EXPECT_NE(message.find(p), std::string::npos) << "message lacks \"" << p << "\": " << message;
}

using ::dbacov::testing::largestAllocationDuring;

// Reference arrays, defined identically here and in Python (kPyReference) so that NumPy and our
// code can be compared value by value. Element i of a descr:
//   '<f4' '<f8': (i - 3) * 0.25          '<i4': (i - 3) * 100000 - 7    '<i8': (i - 3) * 10^12 + 5
//   '|u1': (37 i) mod 256                '|b1': i mod 3 == 0
inline constexpr const char* kPyReference = R"PY(
def ref_values(dt, shape):
    n = int(np.prod(shape, dtype=np.int64))
    i = np.arange(n, dtype=np.int64)
    if dt in ('<f4', '<f8'): v = ((i - 3) * 0.25).astype(dt)
    elif dt == '<i4': v = ((i - 3) * 100000 - 7).astype(dt)
    elif dt == '<i8': v = ((i - 3) * 10**12 + 5).astype(dt)
    elif dt == '|u1': v = ((i * 37) % 256).astype(dt)
    elif dt == '|b1': v = (i % 3 == 0)
    else: raise ValueError(dt)
    return v.reshape(shape)
)PY";

inline NpyArray referenceArray(const std::string& descr, const std::vector<std::size_t>& shape) {
  std::size_t n = 1;
  for (std::size_t d : shape) n *= d;
  auto idx = [](std::size_t i) { return static_cast<std::int64_t>(i); };
  if (descr == "<f4" || descr == "<f8") {
    std::vector<double> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<double>(idx(i) - 3) * 0.25;
    return descr == "<f8" ? makeNpy(v, shape)
                          : makeNpy(std::vector<float>(v.begin(), v.end()), shape);
  }
  if (descr == "<i4") {
    std::vector<std::int32_t> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::int32_t>((idx(i) - 3) * 100000 - 7);
    return makeNpy(v, shape);
  }
  if (descr == "<i8") {
    std::vector<std::int64_t> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = (idx(i) - 3) * 1000000000000LL + 5;
    return makeNpy(v, shape);
  }
  std::vector<std::uint8_t> v(n);
  for (std::size_t i = 0; i < n; ++i)
    v[i] = static_cast<std::uint8_t>(descr == "|u1" ? (i * 37) % 256 : (i % 3 == 0));
  NpyArray a = makeNpy(v, shape);
  if (descr == "|b1") a.dtype = NpyArray::DType::Bool;
  return a;
}

/// Python literal of a shape: "()", "(5,)", "(2, 3)".
inline std::string pyTuple(const std::vector<std::size_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

}  // namespace dbacov::io::testing
