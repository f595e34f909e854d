#pragma once
// The axes of the RGB lattices (spectral lattice and Jakob-Hanika table): n breakpoints of linear
// RGB in [0, 1] at uniform sRGB-encoded steps, v_i = sRGB_decode(i / (n - 1)), so that cells are
// finer near black where a linear step is most visible; and a cell locator without pow() per value.
#include <cstddef>
#include <vector>

namespace spectex {

// IEC 61966-2-1 transfer functions (piecewise: linear segment below 0.04045 / 0.0031308).
double srgb_decode(double v);
double srgb_encode(double x);

class AxisLocator {
  public:
    AxisLocator() = default;
    explicit AxisLocator(int n);  // n >= 2 breakpoints

    int size() const { return static_cast<int>(axis_.size()); }
    const std::vector<double>& axis() const { return axis_; }

    // Cell i in [0, n-2] with axis[i] <= x < axis[i+1] (x = 1 gives n-2), and the local coordinate
    // t = (x - axis[i]) / (axis[i+1] - axis[i]) in [0, 1], in linear units. x is clamped to [0, 1]
    // first (NaN becomes 0). Reference path: sRGB-encodes to guess, then corrects by comparison.
    int locate(double x, double* t) const;

    // The fast path for floats: a lookup table over [0, 1] with a power-of-two number of buckets
    // M (x * M is exact, so the bucket is exact), each containing at most one breakpoint, gives a
    // candidate cell that one comparison corrects. The cell is exact with respect to the float
    // breakpoints (lower_f), which can differ from locate()'s double ones by a float rounding.
    int locate_fast(float x, float* t) const {
        x = x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f;  // also maps NaN to 0
        int i = lut_[static_cast<size_t>(x * lut_scale_)];
        i += x >= upper_f_[static_cast<size_t>(i)];
        const float u = (x - lower_f_[static_cast<size_t>(i)]) * inv_gap_f_[static_cast<size_t>(i)];
        *t = u < 1.0f ? u : 1.0f;
        return i;
    }

    // Float copies used by locate_fast (lower breakpoint of a cell, the next one, 1 / gap).
    const std::vector<float>& lower_f() const { return lower_f_; }

  private:
    std::vector<double> axis_;
    std::vector<float> lower_f_, upper_f_, inv_gap_f_;  // per cell
    std::vector<int> lut_;
    float lut_scale_ = 0;
};

}  // namespace spectex
