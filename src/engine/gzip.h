// One gzip member (RFC 1952) holding `text`. Written one after another they make a valid .gz
// file (gzip, zcat, zlib's gzread, LAMMPS and OVITO read concatenated members as one stream),
// and a file cut after any member is still valid, so an engine continuing from a checkpoint
// truncates frames.dump.gz at a byte offset as it does frames.dump.
#pragma once

#include <string>
#include <string_view>

namespace granary::engine {

std::string GzipMember(std::string_view text, int level = 6);

}  // namespace granary::engine
