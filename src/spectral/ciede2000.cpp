#include "spectral/ciede2000.h"

#include <cmath>
#include <cstdint>
#include <cstring>

namespace spectex {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kEpsilon = 216.0 / 24389.0;  // (6/29)^3
constexpr double kKappa = 24389.0 / 27.0;     // (29/3)^3
constexpr double k25pow7 = 6103515625.0;      // 25^7

double lab_f(double t) { return t > kEpsilon ? std::cbrt(t) : (kKappa * t + 16.0) / 116.0; }

// The cube root of t > 0 without libm (whose cbrt splits t with frexp and ldexp, the larger part
// of a whole-cube pass): a first guess from the exponent's bits (within 3.2 %), then two Halley
// steps, each cubing the relative error (3e-2, 1e-5, 1e-14; the largest on 20 million t drawn
// log-uniformly from 1e-4 to 4: 6.4e-15, against libm's cbrt).
// Three Newton steps (one division each too) took 55 % longer and left 1e-12.
double cube_root(double t) {
    uint64_t i;
    std::memcpy(&i, &t, sizeof i);
    i = i / 3 + 0x2a9f7893782da1ceULL;
    double y;
    std::memcpy(&y, &i, sizeof y);
    for (int k = 0; k < 2; ++k) {
        const double y3 = y * y * y;
        y *= (y3 + 2.0 * t) / (2.0 * y3 + t);
    }
    return y;
}

double pow7(double x) {
    double x2 = x * x, x3 = x2 * x;
    return x3 * x3 * x;
}

// Hue angle in degrees, [0, 360); 0 when a = b = 0 (Sharma et al., eq. 7).
double hue_deg(double b, double a) {
    if (a == 0.0 && b == 0.0) return 0.0;
    double h = std::atan2(b, a) / kDeg;
    return h < 0.0 ? h + 360.0 : h;
}

}  // namespace

Lab lab_from_xyz(const Eigen::Vector3d& xyz, const Eigen::Vector3d& white) {
    const double fx = lab_f(xyz(0) / white(0)), fy = lab_f(xyz(1) / white(1)),
                 fz = lab_f(xyz(2) / white(2));
    return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

Lab lab_from_xyz_fast(const Eigen::Vector3d& xyz, const Eigen::Vector3d& white) {
    auto f = [](double t) { return t > kEpsilon ? cube_root(t) : (kKappa * t + 16.0) / 116.0; };
    const double fx = f(xyz(0) / white(0)), fy = f(xyz(1) / white(1)), fz = f(xyz(2) / white(2));
    return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

namespace {

// Per octant of hue (0-45°, 45-90°, ...; each widened by 1° on both sides, so that a hue on an
// octant's edge is covered whichever side it is given), the least T and the largest
// |sin(2·Δθ)| of CIEDE2000's weighting functions, by sampling every 0.01°. Margins: T changes by at
// most 0.042 per degree (the sum of its terms' slopes) and sin(2·Δθ) by at most 0.052, so a
// sample every 0.01° is within 5.2e-4 of the extremes; 1e-3 is taken off (added to) each.
// Index 8: every hue (a colour pair whose two hues are not in one octant).
struct HueBounds {
    double t_min[9], s_max[9];
    HueBounds() {
        for (int k = 0; k <= 8; ++k) {
            const double lo = k < 8 ? 45.0 * k - 1.0 : 0.0,
                         hi = k < 8 ? 45.0 * (k + 1) + 1.0 : 360.0;
            double t = 1e9, sm = 0;
            for (double h = lo; h <= hi + 1e-9; h += 0.01) {
                const double hh = h < 0 ? h + 360.0 : (h >= 360.0 ? h - 360.0 : h);
                const double T = 1.0 - 0.17 * std::cos((hh - 30.0) * kDeg) +
                                 0.24 * std::cos(2.0 * hh * kDeg) +
                                 0.32 * std::cos((3.0 * hh + 6.0) * kDeg) -
                                 0.20 * std::cos((4.0 * hh - 63.0) * kDeg);
                const double dtheta =
                    30.0 * std::exp(-((hh - 275.0) / 25.0) * ((hh - 275.0) / 25.0));
                t = std::min(t, T);
                sm = std::max(sm, std::fabs(std::sin(2.0 * dtheta * kDeg)));
            }
            t_min[k] = t - 1e-3;
            s_max[k] = std::min(1.0, sm + 1e-3);
        }
    }
};

// The octant of the hue of (a, b), by comparisons alone (ties may fall either side: the octants
// are widened to cover them).
int octant(double a, double b) {
    if (b >= 0) {
        if (a >= 0) return b < a ? 0 : 1;
        return b > -a ? 2 : 3;
    }
    if (a < 0) return -b < -a ? 4 : 5;
    return -b > a ? 6 : 7;
}

}  // namespace

double ciede2000_upper_bound(const Lab& c1, const Lab& c2) {
    static const HueBounds hb;
    // sqrt, not hypot (glibc's is several times slower): L*a*b* values are far from overflow.
    const double C1 = std::sqrt(c1.a * c1.a + c1.b * c1.b),
                 C2 = std::sqrt(c2.a * c2.a + c2.b * c2.b);
    const double Cbar7 = pow7(0.5 * (C1 + C2));
    const double G = 0.5 * (1.0 - std::sqrt(Cbar7 / (Cbar7 + k25pow7)));
    const double a1p = (1.0 + G) * c1.a, a2p = (1.0 + G) * c2.a;
    const double C1p = std::sqrt(a1p * a1p + c1.b * c1.b), C2p = std::sqrt(a2p * a2p + c2.b * c2.b);
    const double Cbarp = 0.5 * (C1p + C2p);
    // Both hues in one octant: so is their mean (the formula's h̄'); else any hue.
    int k = 8;
    if (C1p > 0 && C2p > 0) {
        const int k1 = octant(a1p, c1.b), k2 = octant(a2p, c2.b);
        if (k1 == k2) k = k1;
    }
    const double Lm = 0.5 * (c1.L + c2.L) - 50.0;
    const double SL = 1.0 + 0.015 * Lm * Lm / std::sqrt(20.0 + Lm * Lm);
    const double SC = 1.0 + 0.045 * Cbarp;
    const double SHmin = 1.0 + 0.015 * Cbarp * hb.t_min[k];
    const double Cbarp7 = pow7(Cbarp);
    const double RTmax = 2.0 * std::sqrt(Cbarp7 / (Cbarp7 + k25pow7)) * hb.s_max[k];
    // ΔC' exactly; ΔH'² = |Δ(a', b)|² - ΔC'² (the chord and the difference of the radii).
    const double dL = (c2.L - c1.L) / SL, tC = (C2p - C1p) / SC;
    const double da = a2p - a1p, db = c2.b - c1.b;
    const double dH2 = std::max(0.0, da * da + db * db - (C2p - C1p) * (C2p - C1p));
    const double tH = std::sqrt(dH2) / SHmin;
    const double bound2 = dL * dL + tC * tC + tH * tH + RTmax * std::fabs(tC) * tH;
    return std::sqrt(bound2) * (1.0 + 1e-9) + 1e-12;
}

double ciede2000(const Lab& c1, const Lab& c2, double kL, double kC, double kH) {
    // Step 1: C'_i, h'_i
    const double C1 = std::hypot(c1.a, c1.b), C2 = std::hypot(c2.a, c2.b);
    const double Cbar7 = pow7(0.5 * (C1 + C2));
    const double G = 0.5 * (1.0 - std::sqrt(Cbar7 / (Cbar7 + k25pow7)));
    const double a1p = (1.0 + G) * c1.a, a2p = (1.0 + G) * c2.a;
    const double C1p = std::hypot(a1p, c1.b), C2p = std::hypot(a2p, c2.b);
    const double h1p = hue_deg(c1.b, a1p), h2p = hue_deg(c2.b, a2p);

    // Step 2: dL', dC', dH'
    const double dLp = c2.L - c1.L;
    const double dCp = C2p - C1p;
    const double CpProd = C1p * C2p;
    double dhp = 0.0;
    if (CpProd != 0.0) {
        dhp = h2p - h1p;
        if (dhp > 180.0)
            dhp -= 360.0;
        else if (dhp < -180.0)
            dhp += 360.0;
    }
    const double dHp = 2.0 * std::sqrt(CpProd) * std::sin(0.5 * dhp * kDeg);

    // Step 3: the weighting functions
    const double Lbarp = 0.5 * (c1.L + c2.L);
    const double Cbarp = 0.5 * (C1p + C2p);
    double hbarp = h1p + h2p;
    if (CpProd != 0.0) {
        if (std::fabs(h1p - h2p) <= 180.0)
            hbarp *= 0.5;
        else if (hbarp < 360.0)
            hbarp = 0.5 * (hbarp + 360.0);
        else
            hbarp = 0.5 * (hbarp - 360.0);
    }
    const double T =
        1.0 - 0.17 * std::cos((hbarp - 30.0) * kDeg) + 0.24 * std::cos(2.0 * hbarp * kDeg) +
        0.32 * std::cos((3.0 * hbarp + 6.0) * kDeg) - 0.20 * std::cos((4.0 * hbarp - 63.0) * kDeg);
    const double dtheta = 30.0 * std::exp(-((hbarp - 275.0) / 25.0) * ((hbarp - 275.0) / 25.0));
    const double Cbarp7 = pow7(Cbarp);
    const double RC = 2.0 * std::sqrt(Cbarp7 / (Cbarp7 + k25pow7));
    const double l50 = (Lbarp - 50.0) * (Lbarp - 50.0);
    const double SL = 1.0 + 0.015 * l50 / std::sqrt(20.0 + l50);
    const double SC = 1.0 + 0.045 * Cbarp;
    const double SH = 1.0 + 0.015 * Cbarp * T;
    const double RT = -std::sin(2.0 * dtheta * kDeg) * RC;

    const double tL = dLp / (kL * SL), tC = dCp / (kC * SC), tH = dHp / (kH * SH);
    const double d2 = tL * tL + tC * tC + tH * tH + RT * tC * tH;
    return std::sqrt(d2 > 0.0 ? d2 : 0.0);
}

}  // namespace spectex
