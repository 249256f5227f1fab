// granary-lammps: thin main over granary_lammps.
#include <string>
#include <vector>

#include "lammps/cli.h"

int main(int argc, char** argv) { return granary::lammps::LammpsMain(std::vector<std::string>(argv + 1, argv + argc)); }
