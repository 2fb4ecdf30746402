#pragma once
// The veil command line, runnable in-process (cli/app.cpp).

#include <stdexcept>
#include <string>
#include <vector>

namespace veil::cli {

// A command line that does not parse (an unknown command or option, a value out of range):
// exit status 2 from the executable, this exception with rethrow.
struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// Runs `veil args[1] ...` (args[0] is the program name) and returns its exit status. Reports
// go to std::cout, progress, notes, warnings and errors to std::cerr. With rethrow, a failure
// is thrown instead of printed: UsageError, ParseError (file:line:col), ModelError (the
// object), or another std::exception (a file that cannot be written).
int runCommandLine(const std::vector<std::string>& args, bool rethrow = false);

}  // namespace veil::cli
