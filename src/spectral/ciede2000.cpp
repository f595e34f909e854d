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
// of a whole-cube pass): a first guess from the exponent's bits (within about 3 %), then three
// Newton steps, each squaring the relative error (3e-2, 1e-3, 1e-6, 1e-12).
double cube_root(double t) {
    uint64_t i;
    std::memcpy(&i, &t, sizeof i);
    i = i / 3 + 0x2a9f7893782da1ceULL;
    double y;
    std::memcpy(&y, &i, sizeof y);
    for (int k = 0; k < 3; ++k) y -= (y * y * y - t) / (3.0 * y * y);
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

double ciede2000_upper_bound(const Lab& c1, const Lab& c2) {
    // sqrt, not hypot (glibc's is several times slower): L*a*b* values are far from overflow.
    const double C1 = std::sqrt(c1.a * c1.a + c1.b * c1.b),
                 C2 = std::sqrt(c2.a * c2.a + c2.b * c2.b);
    const double Cbar7 = pow7(0.5 * (C1 + C2));
    const double G = 0.5 * (1.0 - std::sqrt(Cbar7 / (Cbar7 + k25pow7)));
    const double a1p = (1.0 + G) * c1.a, a2p = (1.0 + G) * c2.a;
    const double Cbarp =
        0.5 * (std::sqrt(a1p * a1p + c1.b * c1.b) + std::sqrt(a2p * a2p + c2.b * c2.b));
    const double Lm = 0.5 * (c1.L + c2.L) - 50.0;
    const double SL = 1.0 + 0.015 * Lm * Lm / std::sqrt(20.0 + Lm * Lm);
    const double SHmin = 1.0 + 0.015 * 0.36 * Cbarp;  // T >= 0.3621 for every hue
    const double Cbarp7 = pow7(Cbarp);
    const double RC = 2.0 * std::sqrt(Cbarp7 / (Cbarp7 + k25pow7));
    const double dL = (c2.L - c1.L) / SL;
    const double da = a2p - a1p, db = c2.b - c1.b;
    const double bound2 = dL * dL + (1.0 + 0.5 * RC) * (da * da + db * db) / (SHmin * SHmin);
    return std::sqrt(bound2) * (1.0 + 1e-12);
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
