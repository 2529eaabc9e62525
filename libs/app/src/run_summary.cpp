#include "dbacov/app/run_summary.h"

#include <new>
#include <stdexcept>

#include "dbacov/core/errors.h"

namespace dbacov::app {
namespace {

constexpr std::size_t kExamples = 3;

/// "dir/a.npz" → "a.npz", "dir/s.rawlog#3" → "s.rawlog#3".
std::string baseName(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

/// The first clause of a numerical message ("no gauge reaches keyframes 4, 5: they share ..." →
/// "no gauge reaches keyframes 4, 5"); the whole message when that clause would be too short.
std::string reasonOf(const std::string& message) {
  const std::size_t colon = message.find(": ");
  std::string r = colon != std::string::npos && colon >= 20 ? message.substr(0, colon) : message;
  if (r.size() > 120) r = r.substr(0, 117) + "...";
  return r;
}

}  // namespace

const char* failureKindName(FailureKind kind) {
  switch (kind) {
    case FailureKind::InvalidInput:
      return "invalid input";
    case FailureKind::Numerical:
      return "numerical";
    case FailureKind::Output:
      return "output";
    case FailureKind::OutOfMemory:
      return "out of memory";
    case FailureKind::Internal:
      return "internal error";
  }
  return "unknown";
}

FailureKind classifyFailure(const std::exception& e, bool writing) {
  // std::domain_error: a valid result that a format cannot hold (a yaw/pitch/roll covariance at
  // pitch ±90°).
  if (dynamic_cast<const NumericalError*>(&e) || dynamic_cast<const std::domain_error*>(&e))
    return FailureKind::Numerical;
  if (dynamic_cast<const InputError*>(&e))
    return writing ? FailureKind::Output : FailureKind::InvalidInput;
  if (dynamic_cast<const std::bad_alloc*>(&e)) return FailureKind::OutOfMemory;
  return FailureKind::Internal;
}

std::string failureMessage(const std::exception& e) {
  if (dynamic_cast<const std::bad_alloc*>(&e))
    return "out of memory: the process could not allocate what this input needs (for .npz "
           "snapshots, a lower DBACOV_MEMORY_BUDGET refuses such inputs before reading them)";
  return e.what();
}

void RunSummary::fail(FailureKind kind, const std::string& snapshot, const std::string& message) {
  ++failed_;
  Group& g = groups_[kind];
  ++g.count;
  if (g.examples.size() < kExamples)
    g.examples.push_back(baseName(snapshot) +
                         (kind == FailureKind::Numerical ? ": " + reasonOf(message) : ""));
}

std::string RunSummary::line() const {
  std::string s = std::to_string(read) + " snapshots read, " + std::to_string(processed) +
                  " processed, " + std::to_string(failed_) + " failed";
  const char* sep = ": ";
  for (const auto& [kind, g] : groups_) {
    s += sep + std::to_string(g.count) + " " + failureKindName(kind) + " (";
    for (std::size_t i = 0; i < g.examples.size(); ++i) s += (i ? ", " : "") + g.examples[i];
    if (g.count > g.examples.size())
      s += " and " + std::to_string(g.count - g.examples.size()) + " more";
    s += ")";
    sep = ", ";
  }
  if (outputs_not_written_)
    s += "; " + std::to_string(outputs_not_written_) +
         (outputs_not_written_ == 1 ? " output not written" : " outputs not written");
  return s;
}

}  // namespace dbacov::app
