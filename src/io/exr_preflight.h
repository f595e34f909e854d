#pragma once
// A bounded look at an OpenEXR header before OpenEXR opens the file: OpenEXR 3.1 sizes its chunk
// offset tables from the header, so a hostile header (an absurd data window, 1x1 tiles on a huge
// image, a size field larger than the file) makes it allocate gigabytes. Found by fuzzing.
#include <string>

namespace spectex {

// Throws Error("<path>: <cause>") when the header is malformed or describes more than 2^24 chunks
// or 2^31 pixels per part; returns normally otherwise (OpenEXR then reads the file).
void exr_preflight(const std::string& path);

}  // namespace spectex
