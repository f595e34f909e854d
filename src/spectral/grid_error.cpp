#include "spectral/grid_error.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "base/error.h"
#include "base/half.h"
#include "base/task_pool.h"
#include "spectral/ciede2000.h"
#include "spectral/srgb_axis.h"

namespace spectex {

Reconstruction parse_reconstruction(const std::string& name) {
    if (const auto r = kReconstructionNames.find(name)) return *r;
    throw Error("'" + name + "' is not one of " + kReconstructionNames.list());
}

std::string to_string(Reconstruction r) { return kReconstructionNames.name(r); }

Eigen::MatrixXd reconstruction_matrix(const std::vector<double>& bins,
                                      const std::vector<double>& fine, Reconstruction r) {
    if (bins.empty()) throw Error("reconstruction of an empty grid");
    const Eigen::Index n = static_cast<Eigen::Index>(bins.size());
    Eigen::MatrixXd R = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(fine.size()), n);
    for (size_t f = 0; f < fine.size(); ++f) {
        const double l = fine[f];
        const Eigen::Index row = static_cast<Eigen::Index>(f);
        if (r == Reconstruction::Linear) {
            if (l <= bins.front()) {
                R(row, 0) = 1;
            } else if (l >= bins.back()) {
                R(row, n - 1) = 1;
            } else {
                const size_t k = static_cast<size_t>(std::upper_bound(bins.begin(), bins.end(), l) -
                                                     bins.begin()) -
                                 1;
                const double t = (l - bins[k]) / (bins[k + 1] - bins[k]);
                R(row, static_cast<Eigen::Index>(k)) += 1 - t;
                R(row, static_cast<Eigen::Index>(k) + 1) += t;
            }
        } else if (r == Reconstruction::Nearest) {
            size_t best = 0;
            for (size_t k = 1; k < bins.size(); ++k)
                if (std::fabs(bins[k] - l) < std::fabs(bins[best] - l))
                    best = k;  // a tie keeps the shorter bin
            R(row, static_cast<Eigen::Index>(best)) = 1;
        } else {
            // Box k spans [edge_k, edge_{k+1}): edges halfway between centres, the outer ones
            // infinite.
            const double lo = l - 0.5, hi = l + 0.5;
            for (size_t k = 0; k < bins.size(); ++k) {
                const double e0 = k == 0 ? -INFINITY : 0.5 * (bins[k - 1] + bins[k]);
                const double e1 = k + 1 == bins.size() ? INFINITY : 0.5 * (bins[k] + bins[k + 1]);
                const double overlap = std::min(hi, e1) - std::max(lo, e0);
                if (overlap > 0) R(row, static_cast<Eigen::Index>(k)) = overlap;
            }
        }
    }
    return R;
}

WavelengthGrid renderer_grid(double start, double end) {
    if (!(std::isfinite(start) && std::isfinite(end)) || start != std::floor(start) ||
        end != std::floor(end) || !(end > start)) {
        char buf[96];
        std::snprintf(buf, sizeof buf,
                      "the range %g:%g is not two whole wavelengths in nm, START < END", start,
                      end);
        throw Error(buf);
    }
    return WavelengthGrid::uniform_grid(start, end, 1.0);
}

WavelengthGrid observed_renderer_grid(const Observer& observer) {
    const double lo = std::max({kRendererStart, observer.x.lambda.front(),
                                observer.y.lambda.front(), observer.z.lambda.front()});
    const double hi = std::min({kRendererEnd, observer.x.lambda.back(), observer.y.lambda.back(),
                                observer.z.lambda.back()});
    return renderer_grid(std::ceil(lo - 1e-9), std::floor(hi + 1e-9));
}

LightWeights light_weights(const Observer& observer, const Spectrum& light,
                           const WavelengthGrid& fine) {
    const double lo =
        std::max({observer.x.lambda.front(), observer.y.lambda.front(), observer.z.lambda.front()});
    const double hi =
        std::min({observer.x.lambda.back(), observer.y.lambda.back(), observer.z.lambda.back()});
    if (fine.lambda.front() < lo - 1e-9 || fine.lambda.back() > hi + 1e-9) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "observer %s covers %g to %g nm, not the range %g:%g",
                      observer.name.c_str(), lo, hi, fine.lambda.front(), fine.lambda.back());
        throw Error(buf);
    }
    const std::vector<double> x = observer.x.sample(fine), y = observer.y.sample(fine),
                              z = observer.z.sample(fine);
    LightWeights lw;
    lw.name = light.name;
    const Eigen::Index n = static_cast<Eigen::Index>(fine.size());
    lw.W.resize(3, n);
    double norm = 0;
    for (Eigen::Index k = 0; k < n; ++k) {
        const double l = fine.lambda[static_cast<size_t>(k)];
        const double e = light.at_or_dark(l);
        if (!std::isfinite(e) || e < 0)
            throw Error("illuminant " + light.name + " has a negative or non-finite value");
        if (light.lambda.empty() || l < light.lambda.front() || l > light.lambda.back())
            lw.dark_nm += 1;
        lw.W(0, k) = e * x[static_cast<size_t>(k)];
        lw.W(1, k) = e * y[static_cast<size_t>(k)];
        lw.W(2, k) = e * z[static_cast<size_t>(k)];
        norm += lw.W(1, k);
    }
    if (!(norm > 0))
        throw Error("illuminant " + light.name + " times the observer's y is zero on the range");
    lw.W /= norm;
    lw.white = lw.W.rowwise().sum();
    return lw;
}

// Bins of the histogram: a float's bits without its 13 lowest mantissa bits (relative width 2^-10).
namespace {

uint32_t float_bits(float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}
float bits_float(uint32_t u) {
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}
const uint32_t kHistLo = float_bits(1e-9f) >> 13;
const uint32_t kHistHi = float_bits(1e3f) >> 13;

}  // namespace

DeltaEHistogram::DeltaEHistogram() : bins_(kHistHi - kHistLo + 1, 0) {}

void DeltaEHistogram::add(double de, uint64_t index) {
    if (!(de >= 0)) de = 1e3;  // NaN: the worst bin
    if (de > worst_ || count_ == 0) {
        worst_ = de;
        worst_index_ = index;
    }
    sum_ += de;
    ++count_;
    uint32_t b = float_bits(static_cast<float>(std::min(std::max(de, 1e-9), 1e3))) >> 13;
    b = std::min(std::max(b, kHistLo), kHistHi);
    ++bins_[b - kHistLo];
}

void DeltaEHistogram::merge(const DeltaEHistogram& o) {
    if (o.count_ && (o.worst_ > worst_ || count_ == 0)) {
        worst_ = o.worst_;
        worst_index_ = o.worst_index_;
    }
    sum_ += o.sum_;
    count_ += o.count_;
    for (size_t i = 0; i < bins_.size(); ++i) bins_[i] += o.bins_[i];
}

double DeltaEHistogram::percentile(double q) const {
    if (count_ == 0) return 0;
    const uint64_t need = static_cast<uint64_t>(std::ceil(q * static_cast<double>(count_) - 1e-9));
    uint64_t cum = 0;
    for (size_t i = 0; i < bins_.size(); ++i) {
        cum += bins_[i];
        if (cum >= need && cum > 0) {
            const double edge = bits_float((static_cast<uint32_t>(i) + kHistLo + 1) << 13);
            return std::min(edge, worst_);
        }
    }
    return worst_;
}

ErrorStats stats_of(const DeltaEHistogram& h, const std::vector<std::array<uint8_t, 3>>* codes) {
    ErrorStats s;
    s.worst = h.worst();
    s.p99 = h.percentile(0.99);
    s.mean = h.mean();
    s.colours = h.count();
    const uint64_t i = h.worst_index();
    if (codes) {
        if (i < codes->size()) s.worst_code = {{(*codes)[i][0], (*codes)[i][1], (*codes)[i][2]}};
    } else {
        s.worst_code = {{static_cast<int>((i >> 16) & 255), static_cast<int>((i >> 8) & 255),
                         static_cast<int>(i & 255)}};
    }
    return s;
}

const std::array<double, 256>& srgb_code_table() {
    static const std::array<double, 256> table = [] {
        std::array<double, 256> t{};
        for (int i = 0; i < 256; ++i) t[static_cast<size_t>(i)] = srgb_decode(i / 255.0);
        return t;
    }();
    return table;
}

std::vector<ErrorStats> cube_error_linear(const std::vector<Eigen::Matrix3d>& cand,
                                          const Eigen::Matrix3d& ref, const Eigen::Vector3d& white,
                                          int threads) {
    const auto& lin = srgb_code_table();
    threads = std::max(1, std::min(threads, 256));
    std::vector<std::vector<DeltaEHistogram>> hist(static_cast<size_t>(threads),
                                                   std::vector<DeltaEHistogram>(cand.size()));
    auto work = [&](int t) {
        auto& h = hist[static_cast<size_t>(t)];
        for (int r = t; r < 256; r += threads) {
            for (int g = 0; g < 256; ++g) {
                const Eigen::Vector3d rg_ref = ref.col(0) * lin[static_cast<size_t>(r)] +
                                               ref.col(1) * lin[static_cast<size_t>(g)];
                for (int b = 0; b < 256; ++b) {
                    const double vb = lin[static_cast<size_t>(b)];
                    const Eigen::Vector3d rgb(lin[static_cast<size_t>(r)],
                                              lin[static_cast<size_t>(g)], vb);
                    const Lab lr = lab_from_xyz(rg_ref + ref.col(2) * vb, white);
                    const uint64_t index = (static_cast<uint64_t>(r) << 16) |
                                           (static_cast<uint64_t>(g) << 8) |
                                           static_cast<uint64_t>(b);
                    for (size_t i = 0; i < cand.size(); ++i)
                        h[i].add(ciede2000(lr, lab_from_xyz(cand[i] * rgb, white)), index);
                }
            }
        }
    };
    TaskPool::shared().parallel_for(static_cast<size_t>(threads), threads,
                                    [&](size_t t) { work(static_cast<int>(t)); });
    std::vector<ErrorStats> out;
    for (size_t i = 0; i < cand.size(); ++i) {
        for (int t = 1; t < threads; ++t) hist[0][i].merge(hist[static_cast<size_t>(t)][i]);
        out.push_back(stats_of(hist[0][i]));
    }
    return out;
}

std::vector<std::array<uint8_t, 3>> code_sample(int stride) {
    if (stride < 1 || stride > 255) throw Error("sample stride must be 1 to 255");
    std::vector<int> axis;
    for (int v = 0; v < 255; v += stride) axis.push_back(v);
    axis.push_back(255);
    std::vector<std::array<uint8_t, 3>> codes;
    codes.reserve(axis.size() * axis.size() * axis.size());
    for (int r : axis)
        for (int g : axis)
            for (int b : axis)
                codes.push_back(
                    {{static_cast<uint8_t>(r), static_cast<uint8_t>(g), static_cast<uint8_t>(b)}});
    return codes;
}

std::vector<Eigen::Matrix3Xd> method_xyz(const SpectralMethod& m,
                                         const std::vector<Eigen::Matrix3Xd>& light_recon,
                                         const std::vector<float>& r, const std::vector<float>& g,
                                         const std::vector<float>& b, bool half,
                                         const std::vector<float>* rgb_weight) {
    const size_t n = r.size(), bins = static_cast<size_t>(m.bins());
    for (const auto& lr : light_recon)
        if (static_cast<size_t>(lr.cols()) != bins)
            throw Error("method_xyz: light weights do not match the bins");
    std::vector<Eigen::Matrix3Xd> out(light_recon.size(),
                                      Eigen::Matrix3Xd(3, static_cast<Eigen::Index>(n)));
    constexpr size_t kChunk = 4096;
    std::vector<float> spectra(bins * kChunk);
    std::vector<uint16_t> halves(half ? bins * kChunk : 0);
    Eigen::MatrixXd S(static_cast<Eigen::Index>(bins), static_cast<Eigen::Index>(kChunk));
    for (size_t i0 = 0; i0 < n; i0 += kChunk) {
        const size_t c = std::min(kChunk, n - i0);
        if (half) {
            m.expand_half(r.data() + i0, g.data() + i0, b.data() + i0, c, halves.data(), kChunk,
                          rgb_weight);
            for (size_t k = 0; k < bins; ++k)
                for (size_t i = 0; i < c; ++i)
                    S(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(i)) =
                        half_to_float(halves[k * kChunk + i]);
        } else {
            m.expand_float(r.data() + i0, g.data() + i0, b.data() + i0, c, spectra.data(), kChunk);
            for (size_t k = 0; k < bins; ++k)
                for (size_t i = 0; i < c; ++i)
                    S(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(i)) =
                        spectra[k * kChunk + i];
        }
        for (size_t j = 0; j < light_recon.size(); ++j)
            out[j].middleCols(static_cast<Eigen::Index>(i0), static_cast<Eigen::Index>(c)) =
                light_recon[j] * S.leftCols(static_cast<Eigen::Index>(c));
    }
    return out;
}

DeltaEHistogram xyz_error(const Eigen::Matrix3Xd& cand, const Eigen::Matrix3Xd& ref,
                          const Eigen::Vector3d& white, std::vector<double>* each) {
    if (cand.cols() != ref.cols()) throw Error("xyz_error: lists of different lengths");
    DeltaEHistogram h;
    if (each) each->resize(static_cast<size_t>(cand.cols()));
    for (Eigen::Index i = 0; i < cand.cols(); ++i) {
        const double de =
            ciede2000(lab_from_xyz(ref.col(i), white), lab_from_xyz(cand.col(i), white));
        h.add(de, static_cast<uint64_t>(i));
        if (each) (*each)[static_cast<size_t>(i)] = de;
    }
    return h;
}

}  // namespace spectex
