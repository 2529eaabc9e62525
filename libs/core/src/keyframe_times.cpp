// Keyframe identities and representable times. See keyframe_times.h.
#include "dbacov/core/keyframe_times.h"

#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

#include "dbacov/core/errors.h"
#include "dbacov/core/snapshot.h"

namespace dbacov {
namespace {

std::string number(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

}  // namespace

void checkDistinctTstamps(const Snapshot& s) {
  std::map<double, std::size_t> first;
  for (std::size_t k = 0; k < s.tstamp.size(); ++k) {
    const auto [it, inserted] = first.emplace(s.tstamp[k], k);
    if (!inserted)
      throw InputError(s.source + ": key 'tstamp' gives keyframes " + std::to_string(it->second) +
                       " and " + std::to_string(k) + " the same value " + number(s.tstamp[k]) +
                       ": a keyframe is identified by its tstamp (the image index), expected "
                       "distinct values");
  }
}

void checkRepresentableTime(double t, const std::string& what) {
  if (t > 0 && t <= kMaxKeyframeTime) return;
  if (t == 0)
    throw InputError(what +
                     " has the time 0 s, which MRPT reads as \"no time\" (INVALID_TIMESTAMP): "
                     "expected 0 < t <= 1e10 s since 1970; give --start-time T (time = T + "
                     "tstamp / fps, T > 0, e.g. the recording's start in seconds since 1970) or "
                     "'timestamps_s' > 0");
  throw InputError(what + " has the time " + number(t) +
                   " s, which MRPT cannot represent: expected 0 < t <= 1e10 s since 1970; give "
                   "such times (key 'timestamps_s', or --fps with --start-time)");
}

void checkFps(double fps, const std::string& option) {
  if (!(std::isfinite(fps) && fps > 0 && std::isfinite(1.0 / fps)))
    throw std::invalid_argument(option + " " + number(fps) +
                                ": expected a finite positive frame rate (frames per second)");
}

}  // namespace dbacov
