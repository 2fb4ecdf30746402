#include "analysis/runs/memory_check.h"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

#include "lensdata/errors.h"

namespace veil {

double machineMemoryBytes() {
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    double bytes = pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page)
                                         : std::numeric_limits<double>::infinity();
    std::ifstream limit("/sys/fs/cgroup/memory.max");
    std::string text;
    if (limit >> text && text != "max") {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end != text.c_str() && v > 0.0) bytes = std::min(bytes, v);
    }
    return bytes;
}

double residentBytes() {
    std::ifstream statm("/proc/self/statm");
    double pages = 0.0, resident = 0.0;
    if (!(statm >> pages >> resident)) return 0.0;
    return resident * static_cast<double>(sysconf(_SC_PAGE_SIZE));
}

std::string gigabytes(double bytes) {
    std::ostringstream os;
    os << std::setprecision(bytes < 1e9 ? 2 : 3) << bytes / 1e9 << " GB";
    return os.str();
}

void checkMemory(const std::string& object, const std::string& what, double bytes,
                 const std::string& detail, const std::string& advice, double maxBytes) {
    const double limit = maxBytes > 0.0 ? maxBytes : machineMemoryBytes();
    if (!(bytes > limit)) return;
    std::ostringstream m;
    m << "the " << what << " needs about " << gigabytes(bytes) << " (" << detail << "), more than "
      << (maxBytes > 0.0 ? "--max-memory's " : "this machine's ") << gigabytes(limit) << ": "
      << advice << (maxBytes > 0.0 ? ", or raise --max-memory" : "");
    throw ModelError(object, m.str());
}

}  // namespace veil
