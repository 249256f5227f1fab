// `campaign`: the Granary campaign manager (docs/cli.md). Thin: all logic is in granary_runner.
#include <iostream>
#include <string>
#include <vector>

#include "runner/cli.h"

int main(int argc, char** argv) {
  return granary::runner::RunCli(std::vector<std::string>(argv + 1, argv + argc), std::cout, std::cerr);
}
