// One gzip member (RFC 1952) holding `text`. Written one after another they make a valid .gz
// file (gzip, zcat, zlib's gzread, LAMMPS and OVITO read concatenated members as one stream),
// and a file cut after any member is still valid, so an engine continuing from a checkpoint
// truncates frames.dump.gz at a byte offset as it does frames.dump.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <string_view>

namespace granary::rundir {

std::string GzipMember(std::string_view text, int level = 6);

// Runs `write` on `out`, or, when `gzip`, on a memory stream whose text then goes to `out` as
// one gzip member: the writers format a block once, compressed or not.
void WriteBlock(std::FILE* out, bool gzip, const std::function<void(std::FILE*)>& write);

// The bytes WriteBlock would write for `write` (nothing is written anywhere): what a frame
// costs on disk, for the runner's estimate of a campaign's disk.
std::int64_t BlockBytes(bool gzip, const std::function<void(std::FILE*)>& write);

}  // namespace granary::rundir
