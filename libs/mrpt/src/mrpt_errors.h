// Private helper of dbacov_mrpt: readable messages from MRPT exceptions.
#pragma once

#include <string>

namespace dbacov::mrpt_bridge {

/// MRPT exceptions carry a banner, the source location and a stack trace; this keeps only the
/// messages ("outer: inner").
std::string conciseMrptMessage(const std::string& what);

}  // namespace dbacov::mrpt_bridge
