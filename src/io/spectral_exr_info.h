#pragma once
// Reads the header of a spectral OpenEXR (Fichet 2021 layout, ours or another tool's).
#include <openexr.h>

#include <string>
#include <utility>
#include <vector>

namespace spectex {

struct SpectralBin {
    double lambda = 0;    // nm
    std::string channel;  // as spelt in the file, e.g. "T.380,000000nm"
    std::string type;     // "half", "float", "uint"
};

struct SpectralExrInfo {
    std::string path;
    int width = 0, height = 0;
    int data_x0 = 0, data_y0 = 0, data_x1 = -1, data_y1 = -1;
    int display_x0 = 0, display_y0 = 0, display_x1 = -1, display_y1 = -1;
    std::vector<SpectralBin> reflective;  // sorted by wavelength
    int emissive_channels = 0;            // S0..S3.<λ>nm
    std::string sample_type;              // of the reflective channels: "half", "float", "mixed"
    std::string compression;
    bool tiled = false;
    int tile_width = 0, tile_height = 0;
    // Tiled files: "one", "mipmap" or "ripmap", and how level sizes round ("down", "up"). levels
    // holds each level's size (MIP levels; for RIP maps the x levels' widths with the full height,
    // then the y levels' heights with the full width are in rip_x / rip_y instead).
    std::string level_mode = "one", level_rounding = "down";
    std::vector<std::pair<int, int>> levels;
    std::vector<int> rip_x, rip_y;
    int parts = 1;
    bool alpha = false;
    std::string alpha_type;
    bool preview = false;        // R, G, B present
    std::string layout_version;  // spectralLayoutVersion, "" when absent
    bool complete = true;        // every chunk of every level and part is in the file
    std::vector<std::pair<std::string, std::string>> attributes;  // every other attribute, as text
    struct HeaderAttribute {
        std::string name, type, value;  // value as text (attribute_text)
    };
    std::vector<HeaderAttribute> header;  // every attribute of the first part's header, in order
};

// An OpenEXR core error handler that prints nothing (its callers report the error themselves,
// naming the file).
void exr_quiet_errors(exr_const_context_t, exr_result_t, const char*);

// Every chunk the OpenEXR file's offset tables name lies whole within the file (false for a file
// cut short, or one OpenEXR cannot open): the tables' bytes are read, not the pixels.
bool exr_chunks_within_file(const std::string& path);

// Throws Error("<path>: <cause>") for unreadable files and for files with no reflective channels.
SpectralExrInfo read_spectral_exr_info(const std::string& path);

}  // namespace spectex
