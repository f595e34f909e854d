#include "spectral/srgb_axis.h"

#include <algorithm>
#include <cmath>

#include "base/error.h"

namespace spectex {

double srgb_decode(double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}
double srgb_encode(double x) {
    return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
}

AxisLocator::AxisLocator(int n) {
    if (n < 2) throw Error("a lattice axis needs at least 2 breakpoints, got " + std::to_string(n));
    axis_.resize(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i)
        axis_[static_cast<size_t>(i)] = srgb_decode(static_cast<double>(i) / (n - 1));
    axis_.front() = 0.0;
    axis_.back() = 1.0;  // exact ends: black and white vertices are exactly 0 and 1
    const int cells = n - 1;
    lower_f_.resize(static_cast<size_t>(cells));
    upper_f_.resize(static_cast<size_t>(cells));
    inv_gap_f_.resize(static_cast<size_t>(cells));
    double min_gap = 1.0;
    for (int i = 0; i < cells; ++i) {
        const float lo = static_cast<float>(axis_[static_cast<size_t>(i)]);
        const float hi = static_cast<float>(axis_[static_cast<size_t>(i) + 1]);
        lower_f_[static_cast<size_t>(i)] = lo;
        // The last cell has no upper neighbour: a sentinel above 1 keeps the correction in range.
        upper_f_[static_cast<size_t>(i)] = i + 1 < cells ? hi : 2.0f;
        inv_gap_f_[static_cast<size_t>(i)] = 1.0f / (hi - lo);
        min_gap = std::min(min_gap, static_cast<double>(hi) - lo);
    }
    // At least 4096 buckets, and at least two per smallest gap so that no bucket holds two
    // breakpoints (one comparison then finds the cell).
    size_t m = 4096;
    while (static_cast<double>(m) * min_gap < 2.0) m *= 2;
    lut_scale_ = static_cast<float>(m);
    lut_.resize(m + 1);
    int cell = 0;
    for (size_t j = 0; j <= m; ++j) {
        const float x = static_cast<float>(j) / lut_scale_;  // exact
        while (cell + 1 < cells && x >= upper_f_[static_cast<size_t>(cell)]) ++cell;
        lut_[j] = cell;
    }
}

int AxisLocator::locate(double x, double* t) const {
    x = x > 0.0 ? std::min(x, 1.0) : 0.0;
    const int cells = size() - 1;
    int i = std::clamp(static_cast<int>(std::floor(srgb_encode(x) * cells)), 0, cells - 1);
    // The encode above is rounded; compare with the breakpoints themselves so the cell is right at
    // and around every breakpoint.
    while (i > 0 && x < axis_[static_cast<size_t>(i)]) --i;
    while (i + 1 < cells && x >= axis_[static_cast<size_t>(i) + 1]) ++i;
    const double lo = axis_[static_cast<size_t>(i)], hi = axis_[static_cast<size_t>(i) + 1];
    *t = std::clamp((x - lo) / (hi - lo), 0.0, 1.0);
    return i;
}

}  // namespace spectex
