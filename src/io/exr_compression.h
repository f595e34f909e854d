#pragma once
// The OpenEXR compressions spectex knows, one row each: the only place that says what each is
// called, its id in the header, how many scanlines a chunk holds, which of our writers writes it
// and whether OpenEXR may change samples with it. Options, help, the writers, the header readers
// and the preflight all read this table; tests/unit/exr_compression_test.cpp checks it against
// OpenEXR and checks the lists in docs/file-format.md and the man page against it.
#include <string>
#include <vector>

namespace spectex {

struct ExrCompression {
    std::string name;          // as --compression, info and verify spell it
    int id = 0;                // the header's byte (Imf::Compression, exr_compression_t alike)
    int lines_per_chunk = 1;   // scanlines per chunk of a scanline file
    bool core_writer = false;  // written by the core-API writer (io/exr_core_writer.h); else by Imf
    bool lossy = false;        // OpenEXR may change samples (of some channel types or names)

    // spectex's default (bake, the writer): lossless, 16 lines a chunk, read fast by renderers.
    static constexpr const char* kDefault = "zip";

    static const std::vector<ExrCompression>& all();             // in id order
    static ExrCompression parse(const std::string& name);        // throws Error listing valid names
    static const ExrCompression* find(const std::string& name);  // nullptr when unknown
    static const ExrCompression* find(int id);                   // nullptr when unknown
    static std::vector<std::string> names();
    // Whether OpenEXR may change samples of this sample type (half, else float): pxr24 keeps half
    // exactly and b44/b44a keep float exactly; dwaa/dwab may change either. bake refuses these
    // unless --allow-lossy (a 1 % share of samples outside [0, 1] and a colour error of 20 ΔE00
    // were measured from b44 on an 8-bit albedo).
    bool lossy_for(bool half_samples) const;
    // "lossy", "lossy for half" or "lossy for float"; "" when lossless for both.
    std::string lossy_text() const;
    // The lossless names, in table order, joined like list().
    static std::string lossless_list(const std::string& separator,
                                     const std::string& last_separator);
    // Every name, in table order, joined, the lossy ones marked: list(", ", " or ") gives
    // "none, rle, ..., b44 (lossy for half), ..., dwaa (lossy) or dwab (lossy)".
    static std::string list(const std::string& separator, const std::string& last_separator);
};

}  // namespace spectex
