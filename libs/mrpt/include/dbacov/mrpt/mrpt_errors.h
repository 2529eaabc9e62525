// Readable messages from MRPT exceptions (for the apps and the MRPT bridge).
#pragma once

#include <string>

namespace dbacov::mrpt_bridge {

/// MRPT exceptions carry a banner, the source location and a stack trace; this keeps only the
/// messages ("outer: inner").
std::string conciseMrptMessage(const std::string& what);

}  // namespace dbacov::mrpt_bridge
