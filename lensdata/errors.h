#pragma once
// Errors for bad input and inconsistent models.
//
// Per-ray outcomes are never exceptions (see tracer/sequential/ray_status.h); these are thrown only
// when the user's input cannot be used. A ParseError always names file:line:col, a ModelError
// always names the object at fault.

#include <ostream>
#include <stdexcept>
#include <string>

namespace veil {

// A position in an input file. line and column count from 1; 0 means "unknown".
struct FileLoc {
    std::string file;
    int line = 0;
    int column = 0;

    std::string str() const;  // "file:line:col" (parts that are unknown are left out)
};
std::ostream& operator<<(std::ostream& os, const FileLoc& loc);

// A number as messages write it: a stream's default, 6 significant digits ("0.25", "1e-07").
std::string messageNumber(double value);

// Input that cannot be read: malformed syntax, unknown key, value of the wrong type.
class ParseError : public std::runtime_error {
  public:
    ParseError(FileLoc loc, const std::string& message);
    const FileLoc& loc() const { return loc_; }
    const std::string& message() const { return message_; }

  private:
    FileLoc loc_;
    std::string message_;
};

// A model that parses but makes no physical sense: unknown glass, negative edge thickness,
// colliding parts. `object` names the culprit as users know it ("L3.front", "spacer2").
class ModelError : public std::runtime_error {
  public:
    ModelError(const std::string& object, const std::string& message);
    const std::string& object() const { return object_; }

  private:
    std::string object_;
};

}  // namespace veil
