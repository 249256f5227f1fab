// The command line of granary-lammps (docs/lammps.md).
#pragma once

#include <string>
#include <vector>

namespace granary::lammps {

int LammpsMain(const std::vector<std::string>& args);

}  // namespace granary::lammps
