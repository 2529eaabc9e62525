// The three kinds of failure (CONTRIBUTING.md): misuse (std::invalid_argument / std::logic_error),
// bad input or I/O (InputError), numerical outcomes of a valid input (NumericalError).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace dbacov {

/// Bad input or I/O: the message names the file/snapshot, the key or item, and what was expected.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A valid snapshot whose information matrix cannot give covariances: a graph part that no gauge
/// reaches, an indefinite or numerically singular reduced system. `keyframes()` lists the keyframes
/// involved (indices into the snapshot's `poses`).
class NumericalError : public std::runtime_error {
 public:
  NumericalError(const std::string& what, std::vector<int> keyframes)
      : std::runtime_error(what), keyframes_(std::move(keyframes)) {}
  const std::vector<int>& keyframes() const { return keyframes_; }

 private:
  std::vector<int> keyframes_;
};

/// "1, 2, 5" — for messages that name keyframes.
std::string joinKeyframes(const std::vector<int>& keyframes);

}  // namespace dbacov
