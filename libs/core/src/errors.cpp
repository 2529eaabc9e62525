#include "dbacov/core/errors.h"

namespace dbacov {

std::string joinKeyframes(const std::vector<int>& keyframes) {
  std::string s;
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    if (i) s += ", ";
    s += std::to_string(keyframes[i]);
  }
  return s;
}

}  // namespace dbacov
