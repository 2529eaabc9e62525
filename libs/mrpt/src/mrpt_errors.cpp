#include "mrpt_errors.h"

#include <sstream>

namespace dbacov::mrpt_bridge {

std::string conciseMrptMessage(const std::string& what) {
  std::istringstream in(what);
  std::string out;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Location:", 0) == 0 || line.rfind("Call stack", 0) == 0) break;
    if (line.empty() || line.rfind("====", 0) == 0 || line == "Original exception:") continue;
    if (line.rfind("Message:", 0) == 0) line = line.substr(8);
    const auto first = line.find_first_not_of(' ');
    if (first == std::string::npos) continue;
    if (!out.empty()) out += ": ";
    out += line.substr(first);
  }
  return out.empty() ? what : out;
}

}  // namespace dbacov::mrpt_bridge
