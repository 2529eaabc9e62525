// Keyframe identities and times that every output can represent.
//
//   - A keyframe is identified by its `tstamp` (DROID's image index): --emit final, the plots and
//     the scene merge keyframes of different snapshots by it, so within one snapshot the values
//     must be distinct (checkDistinctTstamps, called by Snapshot::validate).
//   - MRPT stores times as 100 ns ticks since 1601 and reads 0 as "no time" (INVALID_TIMESTAMP):
//     a keyframe time that goes into a rawlog (a pose rawlog's records, a snapshot rawlog's
//     object time) or a graph's node times must be finite and in (0, kMaxKeyframeTime] seconds
//     since 1970 (checkRepresentableTime, called by keyframeTime()). Time 0 — DROID's first
//     tstamp at --fps without --start-time — is refused there with the fix (--start-time); the
//     tables (time_s columns) and the snapshot's own 'timestamps_s' array keep it.
//   - --fps must be finite and positive, and tstamp / fps + start must give such times
//     (checkFps, deriveKeyframeTimes).
#pragma once

#include <string>

namespace dbacov {

struct Snapshot;

/// Largest keyframe time accepted, seconds since 1970 (about the year 2286).
constexpr double kMaxKeyframeTime = 1e10;

/// Throws InputError naming `source` when two keyframes share a tstamp value.
void checkDistinctTstamps(const Snapshot& s);

/// Throws InputError "<what> has the time <t> s, which MRPT cannot represent: ..." unless
/// 0 < t <= kMaxKeyframeTime ("<what> has the time 0 s, which MRPT reads as "no time" ...: give
/// --start-time T ..." for t = 0).
void checkRepresentableTime(double t, const std::string& what);

/// Throws std::invalid_argument naming `option` unless `fps` is finite and positive (NaN, inf,
/// 0 and negative rates are refused; so is a rate so small that tstamp 1 gives no finite time).
void checkFps(double fps, const std::string& option = "--fps");

}  // namespace dbacov
