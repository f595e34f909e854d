// JakobHanikaTable: pbrt-v4's RGBToSpectrumTable layout, fitted on the colorimetry's own grid.
#include <algorithm>
#include <chrono>
#include <cmath>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#endif

#include "base/error.h"
#include "spectral/jakob_hanika.h"

namespace spectex {

namespace {

double smoothstep(double x) { return x * x * (3.0 - 2.0 * x); }

}  // namespace

JakobHanikaTable JakobHanikaTable::build(const Colorimetry& c, int res) {
    const auto t0 = std::chrono::steady_clock::now();
    if (res < 3) throw Error("Jakob-Hanika table needs res >= 3, got " + std::to_string(res));
    JakobHanikaTable t;
    t.res_ = res;
    t.scale_.resize(static_cast<size_t>(res));
    for (int i = 0; i < res; ++i)
        t.scale_[static_cast<size_t>(i)] =
            smoothstep(smoothstep(static_cast<double>(i) / (res - 1)));
    t.scale_f_.assign(t.scale_.begin(), t.scale_.end());

    // The path: for each channel l and each (x, y), start at m index res/5 (warm-started from the
    // previous (x, y) there), then up to m = 1 and down to m = 0, each node from its neighbour in
    // m.
    const size_t r = static_cast<size_t>(res), nodes = 3 * r * r * r;
    std::vector<Eigen::Vector3d> rgb;
    std::vector<int> from;
    std::vector<size_t> slot;  // table index of path entry
    rgb.reserve(nodes + 1), from.reserve(nodes + 1), slot.reserve(nodes + 1);
    const int zs = res / 5;
    // Every node with m = 0 is black: fitted once (the first entry) and the others start from it.
    const int black = [&] {
        rgb.push_back(Eigen::Vector3d::Zero());
        from.push_back(-1);
        slot.push_back(0);
        return 0;
    }();
    for (int l = 0; l < 3; ++l) {
        int prev_start = -1;
        for (int yi = 0; yi < res; ++yi)
            for (int xi = 0; xi < res; ++xi) {
                auto add = [&](int zi, int start) {
                    rgb.push_back(t.node_rgb(l, zi, yi, xi));
                    from.push_back(start);
                    slot.push_back(((static_cast<size_t>(l) * r + static_cast<size_t>(zi)) * r +
                                    static_cast<size_t>(yi)) *
                                       r +
                                   static_cast<size_t>(xi));
                    return static_cast<int>(rgb.size()) - 1;
                };
                const int start = add(zs, prev_start);
                prev_start = start;
                int p = start;
                for (int zi = zs + 1; zi < res; ++zi) p = add(zi, p);
                p = start;
                for (int zi = zs - 1; zi >= 1; --zi) p = add(zi, p);
                add(0, black);
            }
    }
    const std::vector<JHCoefficients> k =
        fit_jakob_hanika_path(c, rgb, from, &t.max_rgb_residual, &t.max_lab_residual);
    t.coeff_.resize(3 * nodes);
    t.nm_.resize(nodes);
    for (size_t i = 0; i < k.size(); ++i) {
        const Eigen::Vector3d a = jh_unit_coefficients(c.grid, k[i]);
        for (size_t j = 0; j < 3; ++j)
            t.coeff_[3 * slot[i] + j] = static_cast<float>(a[static_cast<Eigen::Index>(j)]);
        t.nm_[slot[i]] = k[i];
    }
    const double lo = c.grid.lambda.front(), span = c.grid.lambda.back() - lo;
    t.u_.resize(c.grid.size());
    for (size_t b = 0; b < c.grid.size(); ++b)
        t.u_[b] = static_cast<float>((c.grid.lambda[b] - lo) / span);
    t.grey_cap_ = static_cast<float>(kJHCoefficientCap);
    t.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return t;
}

Eigen::Vector3d JakobHanikaTable::node_rgb(int l, int zi, int yi, int xi) const {
    // In float, as a pixel holding this colour would be (so a lookup at the node lands on it).
    const float z = scale_f_[static_cast<size_t>(zi)];
    const float x = static_cast<float>(xi) / static_cast<float>(res_ - 1) * z;
    const float y = static_cast<float>(yi) / static_cast<float>(res_ - 1) * z;
    Eigen::Vector3d rgb;
    rgb[l] = z;
    rgb[(l + 1) % 3] = x;
    rgb[(l + 2) % 3] = y;
    return rgb;
}

JHCoefficients JakobHanikaTable::node(int l, int zi, int yi, int xi) const {
    const size_t r = static_cast<size_t>(res_);
    return nm_[((static_cast<size_t>(l) * r + static_cast<size_t>(zi)) * r +
                static_cast<size_t>(yi)) *
                   r +
               static_cast<size_t>(xi)];
}

void JakobHanikaTable::coefficients(const float in[3], float k[3]) const {
    float rgb[3];
    for (int c = 0; c < 3; ++c) rgb[c] = in[c] > 0.0f ? std::min(in[c], 1.0f) : 0.0f;  // NaN -> 0
    if (rgb[0] == rgb[1] && rgb[1] == rgb[2]) {
        // Grey: the constant spectrum v, S(c2) = v exactly; black and white at the cap.
        const float v = rgb[0];
        const float c2 = v <= 0.0f   ? -grey_cap_
                         : v >= 1.0f ? grey_cap_
                                     : (v - 0.5f) / std::sqrt(v * (1.0f - v));
        k[0] = k[1] = 0.0f;
        k[2] = std::max(-grey_cap_, std::min(grey_cap_, c2));
        return;
    }
    const int l = rgb[0] > rgb[1] ? (rgb[0] > rgb[2] ? 0 : 2) : (rgb[1] > rgb[2] ? 1 : 2);
    const float z = rgb[l];  // > 0: not grey, so the maximum is above the minimum >= 0
    const float fr = static_cast<float>(res_ - 1);
    const float xs = rgb[(l + 1) % 3] / z * fr, ys = rgb[(l + 2) % 3] / z * fr;
    const int xi = std::min(static_cast<int>(xs), res_ - 2),
              yi = std::min(static_cast<int>(ys), res_ - 2);
    const int zi = std::max(
        0, std::min(static_cast<int>(std::upper_bound(scale_f_.begin(), scale_f_.end(), z) -
                                     scale_f_.begin()) -
                        1,
                    res_ - 2));
    const float dx = xs - static_cast<float>(xi), dy = ys - static_cast<float>(yi);
    const float dz = (z - scale_f_[static_cast<size_t>(zi)]) /
                     (scale_f_[static_cast<size_t>(zi) + 1] - scale_f_[static_cast<size_t>(zi)]);
    const size_t r = static_cast<size_t>(res_);
    const size_t base =
        ((static_cast<size_t>(l) * r + static_cast<size_t>(zi)) * r + static_cast<size_t>(yi)) * r +
        static_cast<size_t>(xi);
    k[0] = k[1] = k[2] = 0.0f;
    for (int corner = 0; corner < 8; ++corner) {
        const int bz = corner >> 2, by = (corner >> 1) & 1, bx = corner & 1;
        const float w = (bz ? dz : 1 - dz) * (by ? dy : 1 - dy) * (bx ? dx : 1 - dx);
        const size_t idx = base + static_cast<size_t>(bz) * r * r + static_cast<size_t>(by) * r +
                           static_cast<size_t>(bx);
        for (size_t j = 0; j < 3; ++j) k[j] += w * coeff_[3 * idx + j];
    }
}

void JakobHanikaTable::spectrum(const float rgb[3], float* out) const {
    float k[3];
    coefficients(rgb, k);
    for (size_t b = 0; b < u_.size(); ++b) {
        const float x = (k[0] * u_[b] + k[1]) * u_[b] + k[2];
        out[b] = 0.5f + 0.5f * x / std::sqrt(1.0f + x * x);
    }
}

namespace {

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
bool jh_have_avx() {
    static const bool yes = __builtin_cpu_supports("avx");  // libgcc also checks the OS (XCR0)
    return yes;
}

// One bin of len pixels, eight at a time; the operations and their order are spectrum()'s, and
// sqrt and division are correctly rounded, so the bits are the same.
__attribute__((target("avx"))) size_t sigmoid_row_avx(const float* k0, const float* k1,
                                                      const float* k2, float u, size_t len,
                                                      float* dst) {
    const __m256 vu = _mm256_set1_ps(u), half = _mm256_set1_ps(0.5f), one = _mm256_set1_ps(1.0f);
    size_t i = 0;
    for (; i + 8 <= len; i += 8) {
        const __m256 x = _mm256_add_ps(
            _mm256_mul_ps(
                _mm256_add_ps(_mm256_mul_ps(_mm256_load_ps(k0 + i), vu), _mm256_load_ps(k1 + i)),
                vu),
            _mm256_load_ps(k2 + i));
        const __m256 s = _mm256_sqrt_ps(_mm256_add_ps(one, _mm256_mul_ps(x, x)));
        _mm256_storeu_ps(dst + i, _mm256_add_ps(half, _mm256_div_ps(_mm256_mul_ps(half, x), s)));
    }
    return i;
}
#else
bool jh_have_avx() { return false; }
size_t sigmoid_row_avx(const float*, const float*, const float*, float, size_t, float*) {
    return 0;
}
#endif

}  // namespace

void JakobHanikaTable::expand(const float* r, const float* g, const float* b, size_t n, float* out,
                              size_t plane_stride) const {
    constexpr size_t kBlock = 256;
    alignas(32) float k0[kBlock], k1[kBlock], k2[kBlock];
    const bool avx = jh_have_avx();
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        for (size_t i = 0; i < len; ++i) {
            const float rgb[3] = {r[i0 + i], g[i0 + i], b[i0 + i]};
            float k[3];
            coefficients(rgb, k);
            k0[i] = k[0], k1[i] = k[1], k2[i] = k[2];
        }
        for (size_t bin = 0; bin < u_.size(); ++bin) {
            const float u = u_[bin];
            float* dst = out + bin * plane_stride + i0;
            size_t i = avx ? sigmoid_row_avx(k0, k1, k2, u, len, dst) : 0;
#if defined(__SSE2__)
            // sqrtps directly: the scalar sqrtf keeps an errno path that stops the vectoriser.
            // Same operations in the same order as spectrum(), so the same bits.
            const __m128 vu = _mm_set1_ps(u), half = _mm_set1_ps(0.5f), one = _mm_set1_ps(1.0f);
            for (; i + 4 <= len; i += 4) {
                const __m128 x = _mm_add_ps(
                    _mm_mul_ps(_mm_add_ps(_mm_mul_ps(_mm_load_ps(k0 + i), vu), _mm_load_ps(k1 + i)),
                               vu),
                    _mm_load_ps(k2 + i));
                const __m128 s = _mm_sqrt_ps(_mm_add_ps(one, _mm_mul_ps(x, x)));
                _mm_storeu_ps(dst + i, _mm_add_ps(half, _mm_div_ps(_mm_mul_ps(half, x), s)));
            }
#endif
            for (; i < len; ++i) {
                const float x = (k0[i] * u + k1[i]) * u + k2[i];
                dst[i] = 0.5f + 0.5f * x / std::sqrt(1.0f + x * x);
            }
        }
    }
}

}  // namespace spectex
