#pragma once
// A bounded look at an OpenEXR header before OpenEXR opens the file: OpenEXR 3.1 sizes its chunk
// offset tables from the header, so a hostile header (an absurd data window, 1x1 tiles on a huge
// image, a size field larger than the file, a string-vector element or a preview larger than its
// attribute, a channel list longer or shorter than its size, after which OpenEXR reads the rest of
// the header out of step) makes it allocate gigabytes. Found by fuzzing.
#include <map>
#include <string>

namespace spectex {

// Throws Error("<path>: <cause>") when the header is malformed or describes more than 2^24 chunks
// or 2^31 pixels per part; returns normally otherwise (OpenEXR then reads the file). Reads only the
// header's bytes (64 KiB at first, more while the header goes on, at most 64 MiB). When
// `part0_strings` is given, it receives the string attributes of the first part (name -> value):
// what --update needs from an output, without opening it again.
void exr_preflight(const std::string& path,
                   std::map<std::string, std::string>* part0_strings = nullptr);

}  // namespace spectex
