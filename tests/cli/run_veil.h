#pragma once
// Runs the veil executable as a user would, for the command-line tests.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

namespace {

// A whole text file ("" when it cannot be read).
[[maybe_unused]] std::string readText(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

struct VeilRun {
    int exitCode = -1;
    std::string out;  // standard output
    std::string err;  // standard error
};

// Runs veil with the given arguments (a shell fragment) from the source directory.
// `env` is an optional VAR=value prefix for the command.
[[maybe_unused]] VeilRun runVeil(const std::string& args, const std::string& env = "") {
    // One file per test process: ctest runs the command-line tests in parallel processes.
    const std::string errFile =
        ::testing::TempDir() + "veil_cli_stderr_" + std::to_string(getpid()) + ".txt";
    const std::string cmd = std::string("cd ") + VEIL_SOURCE_DIR + " && " + env + " " + VEIL_EXE +
                            " " + args + " 2>" + errFile;
    VeilRun r;
    FILE* pipe = popen(cmd.c_str(), "r");
    if (!pipe) return r;
    std::array<char, 4096> buf{};
    size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) r.out.append(buf.data(), n);
    const int status = pclose(pipe);
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    if (FILE* f = fopen(errFile.c_str(), "r")) {
        while ((n = fread(buf.data(), 1, buf.size(), f)) > 0) r.err.append(buf.data(), n);
        fclose(f);
    }
    return r;
}

}  // namespace
