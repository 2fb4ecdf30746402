#pragma once
// How veil writes numbers and words in its reports: the one home of the small helpers every
// report, table and command shares (before, each file wrote its own).
//
//   join({"a", "b"}, ", ")            "a, b"
//   scientific(1.23456e-4, 3)         "1.23e-04"    (non-finite: "")
//   significant(1.23456e-4, 4)        "0.0001235"   (as a stream writes it: 1.235e-05 below)
//   jsonNumber(v)                     v as JSON, null when not finite
//   formatFlux(1.5e-3, 0.012, "W")    "1.500000e-03 W +- 1.200 %" ("0 W (no hits)" for 0)
//   duration(3725)                    "1h2m5s"      (whole seconds, for an ETA)
//   elapsed(12.34)                    "12.3 s"      (a minute and more: as duration)
//   passesText(2)                     "2 passes"

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace veil {

std::string join(const std::vector<std::string>& parts, const std::string& separator);

// `digits` significant digits in scientific notation; "" for a value that is not finite.
std::string scientific(double value, int digits);

// `digits` significant digits as a stream writes them (fixed or scientific, shortest).
std::string significant(double value, int digits);

nlohmann::json jsonNumber(double value);

// A flux with its relative error (1 sigma) in percent.
std::string formatFlux(double flux, double relativeError, const std::string& unit);

std::string duration(double seconds);
std::string elapsed(double seconds);

// "1 pass", "2 passes".
std::string passesText(long long passes);

}  // namespace veil
