// granary-liggghts: thin main over granary_liggghts.
#include <string>
#include <vector>

#include "liggghts/cli.h"

int main(int argc, char** argv) {
  return granary::liggghts::LiggghtsMain(std::vector<std::string>(argv + 1, argv + argc));
}
