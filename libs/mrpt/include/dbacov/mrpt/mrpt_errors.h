// Readable messages from MRPT exceptions (for the apps and the MRPT bridge).
#pragma once

#include <string>

namespace dbacov::mrpt_bridge {

/// MRPT exceptions carry a banner, the source location and a stack trace; this keeps only the
/// messages ("outer: inner").
/// The result is printable() (MRPT quotes class names read from damaged files verbatim).
std::string conciseMrptMessage(const std::string& what);

/// `text` with every byte outside printable ASCII written as `\xNN`, for text that comes from a
/// file (e.g. a class name in a damaged rawlog) and goes into an error message.
std::string printable(const std::string& text);

}  // namespace dbacov::mrpt_bridge
