#pragma once
// The colours of a texture for `spectex plan --texture FILE`: the grid's error
// over the colours a texture really has, instead of the whole 8-bit cube.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace spectex {

struct TextureColours {
    std::vector<std::array<float, 3>> rgb;  // distinct linear RGB colours, in first-seen order
    uint64_t pixels = 0;                    // pixels read
    uint64_t transparent = 0;               // pixels with alpha 0, left out (a bake makes them 0)
    uint64_t distinct = 0;   // distinct colours found (rgb.size() unless over the cap)
    uint64_t replaced = 0;   // pixels with a NaN or infinity, taken as 0 (as a bake does)
    uint64_t clamped = 0;    // pixels with a channel clamped into [0, 1]
    std::string colorspace;  // the input colour space chosen, and how
};

// Reads `path` as a bake does (io/image_source.h; the colour space from `colorspace`, the file's
// metadata or the config's rules; pipeline/pixel_policy.h's defaults: NaN/Inf -> 0, clamped to
// [0, 1]) and keeps its distinct colours. Above `cap` distinct colours, an evenly spaced subset of
// them in first-seen order (deterministic). Throws Error naming the file.
TextureColours texture_colours(const std::string& path, const std::string& data_dir,
                               const std::string& config, const std::string& colorspace,
                               uint64_t max_pixels, size_t cap);

}  // namespace spectex
