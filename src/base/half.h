#pragma once
// IEEE 754 binary16 conversion without OpenEXR headers (spectral/ stays free of image libraries).
// Round to nearest, ties to even, exactly as Imath::half and the F16C instructions do.
#include <cstdint>
#include <cstring>

namespace spectex {

// The largest finite half value: anything larger in magnitude is stored as infinity.
constexpr float kHalfMax = 65504.0f;

inline uint16_t float_to_half(float f) {
    uint32_t x;
    std::memcpy(&x, &f, 4);
    const uint32_t sign = x & 0x80000000u;
    x ^= sign;
    uint32_t o;
    // From 65520 up, finite values round to Inf in the normal branch below (the carry reaches the
    // exponent); from 65536 up we can say so directly.
    if (x >= 0x47800000u) {
        o = x > 0x7f800000u ? 0x7e00u : 0x7c00u;  // NaN stays NaN (quiet), the rest is Inf
    } else if (x < 0x38800000u) {                 // below 2^-14: subnormal half or zero
        // Adding 0.5 aligns the mantissa so the FPU rounds to nearest even for us.
        const uint32_t magic_u = 0x3f000000u;  // 0.5f
        float magic, fx;
        std::memcpy(&magic, &magic_u, 4);
        std::memcpy(&fx, &x, 4);
        fx += magic;
        uint32_t u;
        std::memcpy(&u, &fx, 4);
        o = u - magic_u;
    } else {
        const uint32_t mant_odd = (x >> 13) & 1u;
        x += 0xc8000fffu;  // rebias exponent (15-127)<<23, plus 0xfff rounding
        x += mant_odd;
        o = x >> 13;
    }
    return static_cast<uint16_t>(o | (sign >> 16));
}

inline float half_to_float(uint16_t h) {
    const uint32_t sign = static_cast<uint32_t>(h & 0x8000u) << 16;
    uint32_t exp = (h >> 10) & 0x1fu;
    uint32_t mant = h & 0x3ffu;
    uint32_t bits;
    if (exp == 0) {
        if (mant == 0) {
            bits = sign;
        } else {  // subnormal: value = mant * 2^-24
            float v = static_cast<float>(mant) * 5.9604644775390625e-08f;
            std::memcpy(&bits, &v, 4);
            bits |= sign;
        }
    } else if (exp == 31) {
        bits = sign | 0x7f800000u | (mant << 13);
    } else {
        bits = sign | ((exp + 112u) << 23) | (mant << 13);
    }
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
}

}  // namespace spectex
