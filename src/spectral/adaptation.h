#pragma once
// Chromatic adaptation and the sRGB transfer function: pure maths, shared by everything that shows
// a spectrum as a colour (sample, render, plot).
#include <Eigen/Dense>

namespace spectex {

// The Bradford cone response matrix (Lam 1985, as in ICC.1 Annex E and Hunt's "The Reproduction
// of Colour"): XYZ -> sharpened LMS.
Eigen::Matrix3d bradford_matrix();

// Von Kries adaptation in Bradford space: M^-1 diag(M dst / M src) M, mapping src_white to
// dst_white exactly. Returns the identity when both whites are equal (no rounding noise).
Eigen::Matrix3d bradford_adaptation(const Eigen::Vector3d& src_white,
                                    const Eigen::Vector3d& dst_white);

// IEC 61966-2-1 sRGB encoding of a linear value, clipped to [0, 1] first (NaN -> 0).
double srgb_encode_clipped(double linear);
// The 8-bit code of a linear value: round(255 * srgb_encode_clipped(v)).
int srgb8(double linear);

}  // namespace spectex
