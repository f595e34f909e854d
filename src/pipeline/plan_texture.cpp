#include "pipeline/plan_texture.h"

#include <algorithm>
#include <cstring>
#include <unordered_map>

#include "io/image_source.h"
#include "io/linearizer.h"
#include "pipeline/pixel_policy.h"

namespace spectex {

namespace {

struct Key {
    uint32_t v[3];
    bool operator==(const Key& o) const {
        return v[0] == o.v[0] && v[1] == o.v[1] && v[2] == o.v[2];
    }
};
struct KeyHash {
    size_t operator()(const Key& k) const {
        uint64_t h = 1469598103934665603ull;
        for (uint32_t x : k.v) h = (h ^ x) * 1099511628211ull;
        return static_cast<size_t>(h ^ (h >> 29));
    }
};

}  // namespace

TextureColours texture_colours(const std::string& path, const std::string& data_dir,
                               const std::string& config, const std::string& colorspace,
                               uint64_t max_pixels, size_t cap) {
    auto src = ImageSource::open(path, max_pixels);
    const SourceInfo& info = src->info();
    Linearizer lin =
        Linearizer::make(ColourRequest{data_dir, config, colorspace, path, info.colour});
    if (!info.is_float) lin.use_code_table(info.bits);
    TextureColours out;
    out.colorspace = lin.input_space() + " (" + lin.how_chosen() + ")";
    const PixelPolicy policy{info.alpha == AlphaKind::Associated, NanPolicy::Replace,
                             RangePolicy::Clamp};
    std::unordered_map<Key, uint32_t, KeyHash> seen;
    std::vector<std::array<float, 3>> all;
    const size_t w = static_cast<size_t>(info.width);
    const int band = static_cast<int>(std::max<size_t>(1, (1u << 20) / std::max<size_t>(1, w)));
    std::vector<float> rgba;
    for (int y0 = 0; y0 < info.height; y0 += band) {
        const int y1 = std::min(info.height, y0 + band);
        const size_t n = w * static_cast<size_t>(y1 - y0);
        rgba.resize(4 * n);
        src->read_rgba(y0, y1, rgba.data());
        const PolicedCounts counts = police_rgba(rgba.data(), n, lin, policy, path, w, y0);
        out.replaced += counts.replaced;
        out.clamped += counts.clamped;
        for (size_t i = 0; i < n; ++i) {
            const float* p = &rgba[4 * i];
            ++out.pixels;
            if (info.alpha != AlphaKind::None && p[3] == 0.0f) {
                ++out.transparent;
                continue;
            }
            Key k;
            std::memcpy(k.v, p, sizeof k.v);
            for (uint32_t& x : k.v)
                if (x == 0x80000000u) x = 0;  // -0 is 0
            if (seen.emplace(k, static_cast<uint32_t>(all.size())).second)
                all.push_back({p[0], p[1], p[2]});
        }
    }
    out.distinct = all.size();
    if (all.size() <= cap) {
        out.rgb = std::move(all);
    } else {
        for (size_t k = 0; k < cap; ++k) out.rgb.push_back(all[k * all.size() / cap]);
    }
    return out;
}

}  // namespace spectex
