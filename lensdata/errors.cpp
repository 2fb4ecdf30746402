#include "lensdata/errors.h"

#include <sstream>

namespace veil {

std::string FileLoc::str() const {
    std::ostringstream os;
    os << (file.empty() ? "<input>" : file);
    if (line > 0) {
        os << ":" << line;
        if (column > 0) os << ":" << column;
    }
    return os.str();
}

std::ostream& operator<<(std::ostream& os, const FileLoc& loc) { return os << loc.str(); }

ParseError::ParseError(FileLoc loc, const std::string& message)
    : std::runtime_error(loc.str() + ": " + message), loc_(std::move(loc)), message_(message) {}

ModelError::ModelError(const std::string& object, const std::string& message)
    : std::runtime_error(object + ": " + message), object_(object) {}

std::string messageNumber(double value) {
    std::ostringstream os;
    os << value;
    return os.str();
}

}  // namespace veil
