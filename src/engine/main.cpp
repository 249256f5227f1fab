// granary-engine: thin main over granary_engine.
#include <string>
#include <vector>

#include "engine/cli.h"

int main(int argc, char** argv) { return granary::engine::EngineMain(std::vector<std::string>(argv + 1, argv + argc)); }
