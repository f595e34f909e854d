#include "pipeline/pixel_policy.h"

#include <algorithm>
#include <cmath>

#include "base/error.h"

namespace spectex {

std::string to_string(RangePolicy p) { return kRangePolicyNames.name(p); }
std::string to_string(NanPolicy p) { return kNanPolicyNames.name(p); }

PolicedCounts police_rgba(float* rgba, size_t n, const Linearizer& lin, const PixelPolicy& policy,
                          const std::string& input, size_t width, int y0, uint8_t* changed) {
    auto where = [&](size_t i) {
        return "at pixel (" + std::to_string(i % width) + ", " +
               std::to_string(y0 + static_cast<int>(i / width)) + ")";
    };
    if (policy.straighten) {
        for (size_t i = 0; i < n; ++i) {
            const float al = rgba[4 * i + 3];
            if (al > 0 && al != 1)
                for (int c = 0; c < 3; ++c) rgba[4 * i + c] /= al;
        }
    }
    // Under --out-of-range clamp a finite colour beyond 1e12 becomes 1e12 before the transform: a
    // float input of 1e30 overflowed the sRGB curve to infinity, which the NaN policy then replaced
    // with 0 (black where the file says brighter than white). 1e12 stays finite through any power
    // up to 3 and is clamped to 1 below, as any value above 1 is.
    if (policy.range == RangePolicy::Clamp) {
        constexpr float kHuge = 1e12f;
        for (size_t i = 0; i < n; ++i)
            for (int c = 0; c < 3; ++c) {
                float& v = rgba[4 * i + c];
                if (std::isfinite(v) && std::fabs(v) > kHuge) v = std::copysign(kHuge, v);
            }
    }
    lin.apply_rgba(rgba, static_cast<long>(n));
    PolicedCounts counts;
    for (size_t i = 0; i < n; ++i) {
        float* p = &rgba[4 * i];
        bool bad = false, out_of_range = false;
        for (int c = 0; c < 4; ++c) {
            if (!std::isfinite(p[c])) {
                if (policy.nan == NanPolicy::Error)
                    throw Error(input + ": non-finite value " + where(i) + " (--nan error)");
                p[c] = 0.0f;
                bad = true;
            }
        }
        // Colour (c < 3), and alpha (c = 3), a coverage: outside [0, 1] it makes T = A x spectrum
        // leave [0, 1] too (verify then fails the file). Both follow --out-of-range.
        for (int c = 0; c < 4; ++c) {
            if (p[c] < 0.0f || p[c] > 1.0f) {
                if (policy.range == RangePolicy::Error)
                    throw Error(input + (c < 3 ? ": linear value " : ": alpha ") +
                                std::to_string(p[c]) + " outside [0, 1] " + where(i) +
                                " (--out-of-range error)");
                if (policy.range == RangePolicy::Clamp) {
                    counts.clamped_excursion =
                        std::max(counts.clamped_excursion, p[c] < 0.0f ? -p[c] : p[c] - 1.0f);
                    p[c] = std::min(1.0f, std::max(0.0f, p[c]));
                    out_of_range = true;
                }
                // Each spectrum is a combination of r, g, b with weights in [0, 1] summing to one
                // at every wavelength, so no sample is larger in magnitude than the largest of
                // them: checking the linear values here keeps every sample finite. (Float alpha
                // is written as float.)
                if (c < 3 && policy.range == RangePolicy::Keep && policy.keep_limit > 0 &&
                    std::fabs(p[c]) > policy.keep_limit)
                    throw Error(input + ": linear value " + std::to_string(p[c]) + " " + where(i) +
                                " is beyond the largest half value (" +
                                std::to_string(static_cast<int>(policy.keep_limit)) +
                                "), which --out-of-range keep cannot store; bake with --type "
                                "float, or --out-of-range clamp");
            }
        }
        counts.replaced += bad;
        counts.clamped += out_of_range;
        if (changed) changed[i] = bad || out_of_range;
    }
    return counts;
}

}  // namespace spectex
