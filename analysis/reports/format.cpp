#include "analysis/reports/format.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace veil {

std::string join(const std::vector<std::string>& parts, const std::string& separator) {
    std::string out;
    for (size_t i = 0; i < parts.size(); ++i) out += (i ? separator : "") + parts[i];
    return out;
}

std::string scientific(double value, int digits) {
    if (!std::isfinite(value)) return "";
    std::ostringstream os;
    os << std::scientific << std::setprecision(digits - 1) << value;
    return os.str();
}

std::string significant(double value, int digits) {
    std::ostringstream os;
    os << std::setprecision(digits) << value;
    return os.str();
}

nlohmann::json jsonNumber(double value) {
    return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

std::string formatFlux(double flux, double relativeError, const std::string& unit) {
    std::ostringstream os;
    if (flux == 0.0) {
        os << "0 " << unit << " (no hits)";
        return os.str();
    }
    os << std::scientific << std::setprecision(6) << flux << " " << unit << " +- ";
    if (std::isfinite(relativeError))
        os << std::fixed << std::setprecision(3) << 100.0 * relativeError << " %";
    else
        os << "? %";
    return os.str();
}

constexpr double kLongestDurationSeconds = 99.0 * 86400.0;

std::string duration(double s) {
    // Bounded: an ETA far beyond any run (a target error far away) is said as such, not as an
    // hour count that overflows an int.
    if (!(s >= 0.0)) s = 0.0;
    if (s >= kLongestDurationSeconds) return "more than 99 days";
    std::ostringstream os;
    if (s >= 3600) os << static_cast<int>(s / 3600) << "h";
    if (s >= 60) os << static_cast<int>(std::fmod(s, 3600) / 60) << "m";
    os << static_cast<int>(std::fmod(s, 60)) << "s";
    return os.str();
}

std::string elapsed(double s) {
    if (s >= 60.0) return duration(s);
    std::ostringstream os;
    os << std::fixed << std::setprecision(1) << s << " s";
    return os.str();
}

std::string passesText(long long n) { return std::to_string(n) + (n == 1 ? " pass" : " passes"); }

}  // namespace veil
