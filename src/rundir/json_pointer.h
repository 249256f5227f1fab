// JSON Pointer (RFC 6901) tokens: the paths that every spec error names.
#pragma once

#include <string>

namespace granary {

// `token` escaped for use as one step of a JSON Pointer ("~" as "~0", "/" as "~1").
std::string EscapePointerToken(const std::string& token);

}  // namespace granary
