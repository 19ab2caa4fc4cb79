// A pre-scan of an OpenEXR file's header(s), before OpenEXR reads them: OpenEXR 3.1 sizes
// an attribute's buffer by the size the file claims (a string attribute claiming 2^31
// bytes allocates 2 GB before the read fails) and a part's offset table by its data
// window. The header format is simple (openexr.com, "OpenEXR File Layout"): per part,
// attributes `name\0 type\0 int32-size value`, ended by an empty name; a multi-part file
// ends its list of headers with one more empty header.
#pragma once

#include <string>
#include <string_view>

namespace lp {

// Throws InputError naming `path` when an attribute claims more bytes than the file has
// left, a part's data window is beyond core/limits.h, or the file is shorter than the
// offset table its data windows need (8 bytes a chunk). Returns the number of parts.
int check_exr_header(const std::string& path, std::string_view bytes);

}  // namespace lp
