// A CLI11 validator for numeric flags (README, "Engineering rules": every flag is
// checked where it is read, naming it). Header-only, for the executables' mains;
// the core's libraries do not use CLI11.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "hullpipe/util/run_id.h"

namespace hullpipe {

/// CLI::Range(lo, hi) that also refuses NaN: CLI::Range lets "nan" through, as
/// every comparison with NaN is false. Accepts any number v with lo <= v <= hi
/// (so also refuses inf beyond the bounds); the error names the value and the
/// range, and CLI11 prefixes the flag.
inline CLI::Validator FiniteRange(double lo, double hi) {
  const std::string range = "[" + CLI::detail::to_string(lo) + ", " + CLI::detail::to_string(hi) + "]";
  return CLI::Validator(
      [lo, hi, range](std::string& s) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(s, v) || !(v >= lo && v <= hi)) return "Value " + s + " not in " + range;
        return {};
      },
      "NUMBER in " + range);
}

/// --run-id's check (run_id.h), for the nodes and the launcher alike: 1 to 16
/// hex digits, not all zero; the error quotes the text, and CLI11 prefixes the
/// flag.
inline CLI::Validator RunIdValidator() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        return ParseRunId(s) ? std::string() : "must be 1 to 16 hex digits, not zero: '" + s + "'";
      },
      "HEX");
}

/// --domain's check: a DDS domain id, 0..kMaxDomainId.
inline CLI::Validator DomainIdRange() { return CLI::Range(0, int(kMaxDomainId)); }

}  // namespace hullpipe
