// The end-of-run account of the apps that read several snapshots (dba-covariance, droid2rawlog):
// how many were read, processed and failed, the failures grouped by kind, and the policy that
// decides what a failure does to the rest of the run (--keep-going / --fail-fast).
#pragma once

#include <cstddef>
#include <exception>
#include <map>
#include <string>
#include <vector>

namespace dbacov::app {

/// Why a snapshot failed, in the three kinds of errors.h plus output and internal errors.
enum class FailureKind {
  InvalidInput,  ///< unreadable, damaged or invalid snapshot (dbacov::InputError while reading)
  Numerical,     ///< a valid snapshot without covariances (dbacov::NumericalError)
  Output,        ///< its results could not be written (dbacov::InputError while writing)
  OutOfMemory,   ///< std::bad_alloc: the snapshot needs more memory than the process may use
  Internal,      ///< anything else (a bug)
};

/// "invalid input", "numerical", "output", "out of memory", "internal error".
const char* failureKindName(FailureKind kind);

/// The kind of the exception `e` thrown while reading/computing (`writing` false) or while
/// writing the results (`writing` true).
FailureKind classifyFailure(const std::exception& e, bool writing);

/// The message of `e` for the user: e.what(), except for std::bad_alloc, whose what() says nothing.
std::string failureMessage(const std::exception& e);

/// What one failure does to the run.
enum class FailurePolicy {
  KeepGoing,  ///< report it, go on with the next snapshot, write the others (default)
  FailFast,   ///< stop at the first failure and commit no output at all
};

class RunSummary {
 public:
  std::size_t read = 0, processed = 0;

  /// Records a failure of `snapshot` (a file name, "file.rawlog#entry", ...). `message` is the
  /// error; for numerical failures its first clause is kept as the reason.
  void fail(FailureKind kind, const std::string& snapshot, const std::string& message);
  std::size_t failed() const { return failed_; }
  /// Records that an output file could not be committed at the end of the run (its error is
  /// reported where it happens).
  void outputNotWritten() { ++outputs_not_written_; }
  std::size_t outputsNotWritten() const { return outputs_not_written_; }

  /// "N snapshots read, P processed, F failed", followed when F > 0 by the failures grouped by
  /// kind: ": 2 invalid input (b.npz, c.npz), 1 numerical (d.npz: no gauge reaches keyframes 4,
  /// 5)". Each group names at most three snapshots (file names without directories), then
  /// "and K more"; numerical failures also give their reason. Then, when some output could not
  /// be committed: "; K outputs not written".
  std::string line() const;

 private:
  struct Group {
    std::size_t count = 0;
    std::vector<std::string> examples;
  };
  std::size_t failed_ = 0;
  std::size_t outputs_not_written_ = 0;
  std::map<FailureKind, Group> groups_;
};

}  // namespace dbacov::app
