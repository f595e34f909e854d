#include "spectral/jakob_hanika.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "base/error.h"

namespace spectex {

double jh_sigmoid(double x) {
    if (std::isinf(x)) return x > 0 ? 1.0 : 0.0;
    return 0.5 + x / (2.0 * std::sqrt(1.0 + x * x));
}

double jh_eval(const JHCoefficients& c, double lambda_nm) {
    return jh_sigmoid((c.c0 * lambda_nm + c.c1) * lambda_nm + c.c2);
}

namespace {

// The fit's own variables: the polynomial in u = (λ - lo) / span.
struct UCoefficients {
    Eigen::Vector3d a{0, 0, 0};  // p(u) = a0 u² + a1 u + a2
};

struct GridMap {
    double lo = 0, span = 1;
    explicit GridMap(const WavelengthGrid& g) {
        if (g.size() < 2) throw Error("Jakob-Hanika fit needs at least 2 wavelengths");
        lo = g.lambda.front();
        span = g.lambda.back() - g.lambda.front();
    }
    JHCoefficients to_nm(const Eigen::Vector3d& a) const {
        const double s2 = span * span;
        return {a[0] / s2, a[1] / span - 2.0 * a[0] * lo / s2,
                a[0] * lo * lo / s2 - a[1] * lo / span + a[2]};
    }
    Eigen::Vector3d from_nm(const JHCoefficients& c) const {
        return {c.c0 * span * span, (c.c1 + 2.0 * c.c0 * lo) * span,
                (c.c0 * lo + c.c1) * lo + c.c2};
    }
};

// CIELAB against the colorimetry's own white (the white-consistent matrix: RGB (1,1,1) is L = 100).
struct Lab {
    Eigen::Matrix3d rgb_to_xyz;
    Eigen::Vector3d white;
    static constexpr double kDelta = 6.0 / 29.0;
    static double f(double t) {
        return t > kDelta * kDelta * kDelta ? std::cbrt(t) : t / (3 * kDelta * kDelta) + 4.0 / 29.0;
    }
    static double df(double t) {
        if (t > kDelta * kDelta * kDelta) {
            const double c = std::cbrt(t);
            return 1.0 / (3.0 * c * c);
        }
        return 1.0 / (3 * kDelta * kDelta);
    }
    // Lab of a linear RGB colour and, when J is given, dLab/dRGB.
    Eigen::Vector3d operator()(const Eigen::Vector3d& rgb, Eigen::Matrix3d* J = nullptr) const {
        const Eigen::Vector3d xyz = rgb_to_xyz * rgb;
        Eigen::Vector3d t = xyz.cwiseQuotient(white), fv, dv;
        for (int i = 0; i < 3; ++i) fv[i] = f(t[i]), dv[i] = df(t[i]) / white[i];
        if (J) {
            Eigen::Matrix3d d = Eigen::Matrix3d::Zero();  // dLab/dXYZ
            d(0, 1) = 116 * dv[1];
            d(1, 0) = 500 * dv[0], d(1, 1) = -500 * dv[1];
            d(2, 1) = 200 * dv[1], d(2, 2) = -200 * dv[2];
            *J = d * rgb_to_xyz;
        }
        return {116 * fv[1] - 16, 500 * (fv[0] - fv[1]), 200 * (fv[1] - fv[2])};
    }
};

struct Fitter {
    Eigen::Matrix3Xd C;
    Eigen::VectorXd u;
    Lab lab;
    GridMap map;

    explicit Fitter(const Colorimetry& c) : C(c.rgb_weights()), map(c.grid) {
        u.resize(static_cast<Eigen::Index>(c.grid.size()));
        for (size_t k = 0; k < c.grid.size(); ++k)
            u[static_cast<Eigen::Index>(k)] = (c.grid.lambda[k] - map.lo) / map.span;
        lab.rgb_to_xyz = c.rgb_to_xyz;
        lab.white = c.white_xyz;
    }

    // RGB of the sigmoid spectrum and, when D is given, dRGB/da.
    Eigen::Vector3d rgb(const Eigen::Vector3d& a, Eigen::Matrix3d* D = nullptr) const {
        Eigen::Vector3d out = Eigen::Vector3d::Zero();
        Eigen::Matrix3d d = Eigen::Matrix3d::Zero();
        for (Eigen::Index k = 0; k < u.size(); ++k) {
            const double x = (a[0] * u[k] + a[1]) * u[k] + a[2];
            const double r = 1.0 / std::sqrt(1.0 + x * x);
            out += C.col(k) * (0.5 + 0.5 * x * r);
            if (D) {
                const double ds = 0.5 * r * r * r;
                const Eigen::Vector3d cd = C.col(k) * ds;
                d.col(0) += cd * (u[k] * u[k]);
                d.col(1) += cd * u[k];
                d.col(2) += cd;
            }
        }
        if (D) *D = d;
        return out;
    }

    static Eigen::Vector3d cap(Eigen::Vector3d a, bool* capped) {
        const double m = a.cwiseAbs().maxCoeff();
        if (m > kJHCoefficientCap) {
            a *= kJHCoefficientCap / m;
            *capped = true;
        }
        return a;
    }

    // Levenberg-Marquardt from a on the Lab residual to target; returns 0.5 ||r||².
    double solve(const Eigen::Vector3d& target_lab, Eigen::Vector3d& a, int max_iter,
                 int* iterations, bool* capped) const {
        Eigen::Matrix3d D, Jl;
        Eigen::Vector3d r = lab(rgb(a, &D), &Jl) - target_lab;
        double cost = 0.5 * r.squaredNorm(), mu = 1e-4;
        int it = 0;
        for (; it < max_iter && cost > 1e-24; ++it) {
            const Eigen::Matrix3d J = Jl * D;
            const Eigen::Matrix3d A = J.transpose() * J;
            const Eigen::Vector3d g = J.transpose() * r;
            bool accepted = false;
            while (mu < 1e16) {
                Eigen::Matrix3d Ad = A;
                // Marquardt scaling with a floor: saturated sigmoids have vanishing derivatives.
                const double floor = 1e-12 * std::max(A.diagonal().maxCoeff(), 1e-300);
                for (int i = 0; i < 3; ++i) Ad(i, i) += mu * std::max(A(i, i), floor);
                const Eigen::Vector3d step = -Ad.ldlt().solve(g);
                if (!step.allFinite()) {
                    mu *= 8;
                    continue;
                }
                bool c = false;
                const Eigen::Vector3d an = cap(a + step, &c);
                Eigen::Matrix3d Dn, Jn;
                const Eigen::Vector3d rn = lab(rgb(an, &Dn), &Jn) - target_lab;
                const double cn = 0.5 * rn.squaredNorm();
                if (cn < cost) {
                    // At the cap the optimum is at infinity and each step only turns the
                    // direction a little: stop once that gains less than 1e-6 of the cost.
                    const bool tiny = cost - cn <= (c ? 1e-6 : 1e-15) * cost;
                    a = an, r = rn, D = Dn, Jl = Jn, cost = cn;
                    *capped = c;
                    mu = std::max(mu / 4, 1e-12);
                    accepted = !tiny;
                    break;
                }
                mu *= 4;
            }
            if (!accepted) break;
        }
        *iterations += it;
        return cost;
    }

    // Fit from a start, then (if the answer is poor) by continuation from grey towards rgb, keeping
    // the best.
    Eigen::Vector3d fit(const Eigen::Vector3d& rgb_in, const Eigen::Vector3d* start,
                        JHFitInfo* info) const {
        Eigen::Vector3d target;
        for (int i = 0; i < 3; ++i)
            target[i] = rgb_in[i] > 0 ? std::min(rgb_in[i], 1.0) : 0.0;  // NaN -> 0
        const Eigen::Vector3d tl = lab(target);
        int iterations = 0;
        bool capped = false;
        Eigen::Vector3d a = start ? *start : Eigen::Vector3d::Zero();
        if (!a.allFinite()) a.setZero();
        a = cap(a, &capped);
        double cost = solve(tl, a, start ? 60 : 100, &iterations, &capped);
        // 0.5 ΔE² > 0.5e-6: not converged, or outside the sigmoid gamut; a path from grey decides.
        // Not when capped close to the colour (ΔE < 1e-3): black and white, whose optimum is at
        // infinity whatever the path (capped ultra-dark saturated colours do gain from the retry:
        // a warm path can stop at a worse point of the cap, e.g. ΔE 0.015 against 0.0025).
        if (cost > 0.5e-6 && !(capped && cost < 0.5 * 1e-3 * 1e-3)) {
            const double grey = std::clamp(target.mean(), 0.05, 0.95);
            Eigen::Vector3d b = Eigen::Vector3d::Zero();
            b[2] = grey < 0.5 ? -0.3 : 0.3;
            bool cb = false;
            double cost_b = 0;
            for (int step = 1; step <= 8; ++step) {
                const double s = step / 8.0;
                const Eigen::Vector3d t = Eigen::Vector3d::Constant(grey) * (1 - s) + target * s;
                cost_b = solve(lab(t), b, 40, &iterations, &cb);
            }
            cost_b = solve(tl, b, 100, &iterations, &cb);
            if (cost_b < cost) a = b, cost = cost_b, capped = cb;
        }
        if (info) {
            info->lab_residual = std::sqrt(2 * cost);
            info->rgb_residual = (rgb(a) - target).cwiseAbs().maxCoeff();
            info->iterations = iterations;
            info->capped = capped;
        }
        return a;
    }
};

}  // namespace

JHCoefficients fit_jakob_hanika(const Colorimetry& c, const Eigen::Vector3d& rgb,
                                const JHCoefficients* start, JHFitInfo* info) {
    const Fitter f(c);
    Eigen::Vector3d s0;
    if (start) s0 = f.map.from_nm(*start);
    return f.map.to_nm(f.fit(rgb, start ? &s0 : nullptr, info));
}

std::vector<JHCoefficients> fit_jakob_hanika_path(const Colorimetry& c,
                                                  const std::vector<Eigen::Vector3d>& rgb,
                                                  const std::vector<int>& start_from,
                                                  double* max_rgb_residual,
                                                  double* max_lab_residual) {
    if (start_from.size() != rgb.size()) throw Error("fit_jakob_hanika_path: sizes differ");
    const Fitter f(c);
    std::vector<Eigen::Vector3d> a(rgb.size(), Eigen::Vector3d::Zero());
    std::vector<JHCoefficients> out(rgb.size());
    double mr = 0, ml = 0;
    for (size_t i = 0; i < rgb.size(); ++i) {
        const int from = start_from[i];
        if (from >= static_cast<int>(i)) throw Error("fit_jakob_hanika_path: start after colour");
        JHFitInfo info;
        a[i] = f.fit(rgb[i], from >= 0 ? &a[static_cast<size_t>(from)] : nullptr, &info);
        out[i] = f.map.to_nm(a[i]);
        mr = std::max(mr, info.rgb_residual);
        ml = std::max(ml, info.lab_residual);
    }
    if (max_rgb_residual) *max_rgb_residual = mr;
    if (max_lab_residual) *max_lab_residual = ml;
    return out;
}

Eigen::Vector3d jh_unit_coefficients(const WavelengthGrid& g, const JHCoefficients& k) {
    return GridMap(g).from_nm(k);
}

// Nodes visited by increasing Chebyshev distance from the centre node, each warm-started from
// the node one step nearer the centre in every coordinate: every path starts at mid grey and runs
// straight out, and neighbours have close optima.
std::vector<JHCoefficients> fit_jakob_hanika_nodes(const Colorimetry& c,
                                                   const std::vector<double>& axis,
                                                   double* max_rgb_residual,
                                                   double* max_lab_residual) {
    const int n = static_cast<int>(axis.size());
    const int mid = (n - 1) / 2;
    std::vector<int> order(static_cast<size_t>(n) * n * n);
    for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
    auto dist = [&](int idx) {
        const int ir = idx / (n * n), ig = idx / n % n, ib = idx % n;
        return std::max({std::abs(ir - mid), std::abs(ig - mid), std::abs(ib - mid)});
    };
    std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return dist(x) < dist(y); });
    std::vector<int> position(order.size());
    for (size_t p = 0; p < order.size(); ++p)
        position[static_cast<size_t>(order[p])] = static_cast<int>(p);
    auto toward = [&](int i) { return i < mid ? i + 1 : (i > mid ? i - 1 : i); };
    std::vector<Eigen::Vector3d> rgb(order.size());
    std::vector<int> from(order.size());
    for (size_t p = 0; p < order.size(); ++p) {
        const int idx = order[p];
        const int ir = idx / (n * n), ig = idx / n % n, ib = idx % n;
        const int parent = (toward(ir) * n + toward(ig)) * n + toward(ib);
        rgb[p] = Eigen::Vector3d(axis[static_cast<size_t>(ir)], axis[static_cast<size_t>(ig)],
                                 axis[static_cast<size_t>(ib)]);
        from[p] = parent == idx ? -1 : position[static_cast<size_t>(parent)];
    }
    const std::vector<JHCoefficients> fitted =
        fit_jakob_hanika_path(c, rgb, from, max_rgb_residual, max_lab_residual);
    std::vector<JHCoefficients> out(order.size());
    for (size_t p = 0; p < order.size(); ++p) out[static_cast<size_t>(order[p])] = fitted[p];
    return out;
}

Eigen::VectorXd jh_spectrum(const Colorimetry& c, const JHCoefficients& k) {
    Eigen::VectorXd s(static_cast<Eigen::Index>(c.grid.size()));
    for (size_t i = 0; i < c.grid.size(); ++i)
        s[static_cast<Eigen::Index>(i)] = jh_eval(k, c.grid.lambda[i]);
    return s;
}

}  // namespace spectex
