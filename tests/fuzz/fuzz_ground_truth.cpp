// libFuzzer target: the ground-truth readers of dba-evaluate. The bytes are one text file, read
// as a ground-truth trajectory in each format (auto: EuRoC when the first data line has commas,
// else TUM; then TUM and EuRoC explicitly) and as an image-time list (--image-times); what reads
// is queried (interpolation between samples, tstamp lookups). See fuzz_target.h for the contract
// (here: InputError only).
#include <cmath>

#include "dbacov/app/evaluation_inputs.h"
#include "dbacov/core/errors.h"
#include "fuzz_scratch.h"
#include "fuzz_target.h"

extern "C" int DBACOV_FUZZ_ENTRY(const std::uint8_t* data, std::size_t size) {
  using dbacov::app::GroundTruth;
  using dbacov::app::GroundTruthFormat;
  const std::string path = dbacov::fuzz::scratchFile("fuzz.gt", data, size);
  for (GroundTruthFormat f :
       {GroundTruthFormat::Auto, GroundTruthFormat::Tum, GroundTruthFormat::Euroc}) {
    try {
      const GroundTruth gt = GroundTruth::load(path, f);
      for (double t : {0.0, 1.0, 1000.0, 1000.05, 1e9, 1403636579.7585554, 1.7e9, 1e18})
        if (const auto T = gt.at(t, 0.01, 1e30); T && !T->matrix().allFinite()) __builtin_trap();
    } catch (const dbacov::InputError&) {
    }
  }
  try {
    const dbacov::app::KeyframeTimes times = dbacov::app::KeyframeTimes::fromFile(path);
    for (double tstamp : {0.0, 1.0, 2.0, 3.5, -1.0, 1e12}) {
      try {
        if (!std::isfinite(times(tstamp))) __builtin_trap();
      } catch (const dbacov::InputError&) {
      }
    }
  } catch (const dbacov::InputError&) {
  }
  return 0;
}
