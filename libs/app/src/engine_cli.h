// Private to dbacov_app: the command-line face of the engine options. Every app that computes
// covariances registers them here, so each flag is declared once and turned into DbaOptions by
// the one builder (DbaOptionOverrides::resolve, core/options.h).
#pragma once

#include <optional>
#include <string>

#include "dbacov/core/options.h"

namespace CLI {
class App;
class Option;
class Validator;
}  // namespace CLI

namespace dbacov::app::detail {

/// Registers --preset, --weight-scale, --gauge, --gauge-sigma-rot, --gauge-sigma-trans, --near,
/// --far and --min-depth-ratio (values land in `o`).
void addEngineOptions(CLI::App& cli, DbaOptionOverrides& o);

/// Registers --solver and --ordering (values land in `o`).
void addCovarianceOptions(CLI::App& cli, CovarianceOptions& o);

/// --weight-scale: information per unit confidence, px^-2. `default_text` says what an unset
/// value means in the app (e.g. "the preset's: droid 0.001, paper 0.1").
CLI::Option* addWeightScaleOption(CLI::App& cli, std::optional<double>& value,
                                  const std::string& default_text);

/// The whole text as an integer (leading blanks allowed, nothing after), or nothing when it is
/// not one or does not fit a long long.
std::optional<long long> parseInteger(const std::string& text);

/// An integer in lo..hi. Other text fails with "'x' is not an integer" or "x is not in lo..hi"
/// (the Python module's wording), where CLI::Range said "Value x not in range" of any text.
CLI::Validator integerIn(long long lo, long long hi);
/// A number in [lo, hi]: "'x' is not a number" or "x is not in [lo, hi]".
CLI::Validator numberIn(double lo, double hi);
/// A finite number > 0 (or >= 0 when `zero_too`): "'x' is not a finite number > 0", where
/// CLI::PositiveNumber printed the largest double in full (309 digits).
CLI::Validator positiveNumber(bool zero_too = false);

/// Accepts the names of enum E (enum_names.h); an other name fails with parseEnum's message, the
/// one the library and the Python module give ("unknown gauge 'x', expected two-pose, ...").
template <class E>
CLI::Validator enumValidator();

/// An option whose text is one of the names of enum E (enum_names.h), stored into `value`.
template <class E>
CLI::Option* addEnumOption(CLI::App& cli, const std::string& flags, E& value,
                           const std::string& description);
template <class E>
CLI::Option* addEnumOption(CLI::App& cli, const std::string& flags, std::optional<E>& value,
                           const std::string& description);

}  // namespace dbacov::app::detail
