// veil: the command-line front end (cli/app.h does the work).

#include <string>
#include <vector>

#include "cli/app.h"

int main(int argc, char** argv) {
    return veil::cli::runCommandLine(std::vector<std::string>(argv, argv + argc));
}
