#pragma once
// What happens to a source pixel before it becomes a spectrum, in one place: bake applies it,
// verify re-applies it to compare, plan --texture applies it to take a texture's colours.
//   1. straighten: colour divided by alpha when the file's alpha is associated (0 < A != 1);
//   2. linearise with the colour config (io/linearizer.h);
//   3. NaN/Inf in any channel become 0 (--nan replace) or are an error naming the pixel (--nan
//   error);
//   4. linear colour outside [0, 1] is clamped per channel (--out-of-range clamp), kept, or an
//   error.
#include <cstddef>
#include <cstdint>
#include <string>

#include "base/enum_names.h"
#include "io/linearizer.h"

namespace spectex {

enum class RangePolicy { Clamp, Keep, Error };
enum class NanPolicy { Replace, Error };
inline constexpr EnumNames<RangePolicy, 3> kRangePolicyNames{
    {{{RangePolicy::Clamp, "clamp"}, {RangePolicy::Keep, "keep"}, {RangePolicy::Error, "error"}}}};
inline constexpr EnumNames<NanPolicy, 2> kNanPolicyNames{
    {{{NanPolicy::Replace, "replace"}, {NanPolicy::Error, "error"}}}};
std::string to_string(RangePolicy p);
std::string to_string(NanPolicy p);

struct PixelPolicy {
    bool straighten = false;  // the file's alpha is associated
    NanPolicy nan = NanPolicy::Replace;
    RangePolicy range = RangePolicy::Clamp;
    // With RangePolicy::Keep: the largest magnitude the output can store (65504 for half), 0 for
    // no limit. A kept value beyond it would be written as infinity: the file fails instead.
    float keep_limit = 0.0f;
};

struct PolicedCounts {
    uint64_t replaced = 0;  // pixels with a non-finite channel
    uint64_t clamped = 0;   // pixels with a colour channel clamped into [0, 1]
    // The largest distance outside [0, 1] of a clamped channel (0 when none was): a config's own
    // arithmetic gives up to kConfigArithmeticTolerance (io/linearizer.h), a wide gamut far more.
    float clamped_excursion = 0.0f;
};

// In place on n packed RGBA pixels, rows of `width` pixels starting at row y0 of `input` (for the
// messages). changed (n bytes, optional): 1 where a pixel was replaced or clamped. Throws Error
// under
// --nan error / --out-of-range error.
PolicedCounts police_rgba(float* rgba, size_t n, const Linearizer& lin, const PixelPolicy& policy,
                          const std::string& input, size_t width, int y0,
                          uint8_t* changed = nullptr);

}  // namespace spectex
