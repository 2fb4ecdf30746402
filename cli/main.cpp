// veil: the command-line front end (cli/app.h does the work).
//
// Under mpirun (docs/scaling.md) every rank runs the same command; rank 0 alone prints and
// writes: the others' standard output goes to /dev/null and their std::cerr is silent, but
// for the message of a failure on that rank (cli/app.cpp), which stops the whole job.

#include <cstdio>
#include <iostream>
#include <optional>
#include <streambuf>
#include <string>
#include <vector>

#include "cli/app.h"
#include "tracer/runtime/ranks.h"

namespace {

// Takes every character and keeps none.
class NullBuffer : public std::streambuf {
  protected:
    int overflow(int c) override { return c == traits_type::eof() ? 0 : c; }
    std::streamsize xsputn(const char*, std::streamsize n) override { return n; }
};

}  // namespace

int main(int argc, char** argv) {
    std::optional<veil::RankSession> session;
    try {
        session.emplace(argc, argv);
    } catch (const std::exception& e) {
        // Every rank fails alike here: the first one says why.
        if (veil::launcherRank() == 0) std::cerr << "veil: error: " << e.what() << "\n";
        return 1;
    }
    static NullBuffer null;
    if (!veil::Ranks::world().root()) {
        if (!std::freopen("/dev/null", "w", stdout)) std::cout.rdbuf(&null);
        std::cerr.rdbuf(&null);
        std::clog.rdbuf(&null);
    }
    return veil::cli::runCommandLine(std::vector<std::string>(argv, argv + argc));
}
