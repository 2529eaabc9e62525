#include "dbacov/mrpt/mrpt_errors.h"

#include <sstream>
#include <vector>

namespace dbacov::mrpt_bridge {

std::string conciseMrptMessage(const std::string& what) {
  std::istringstream in(what);
  std::vector<std::string> messages;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Location:", 0) == 0 || line.rfind("Call stack", 0) == 0) break;
    if (line.empty() || line.rfind("====", 0) == 0 || line == "Original exception:") continue;
    if (line.rfind("Message:", 0) == 0) line = line.substr(8);
    const auto first = line.find_first_not_of(' ');
    if (first != std::string::npos) messages.push_back(line.substr(first));
  }
  // CArchive wraps whatever a deserializer throws in "Exception while parsing typed object 'C'
  // from <stream>": the stream is named by the caller already and the inner message says more.
  const std::string kWrapper = "Exception while parsing typed object";
  if (messages.size() > 1 && messages.front().rfind(kWrapper, 0) == 0)
    messages.erase(messages.begin());
  std::string out;
  for (const std::string& m : messages) out += (out.empty() ? "" : ": ") + m;
  return printable(out.empty() ? what : out);
}

std::string printable(const std::string& text) {
  static const char* const kHex = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7f) {
      out += c;
    } else {
      out += "\\x";
      out += kHex[u >> 4];
      out += kHex[u & 15];
    }
  }
  return out;
}

}  // namespace dbacov::mrpt_bridge
