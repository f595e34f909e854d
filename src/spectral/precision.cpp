#include "spectral/precision.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "base/error.h"
#include "base/half.h"
#include "base/task_pool.h"
#include "base/text.h"
#include "spectral/ciede2000.h"
#include "spectral/colorimetry.h"
#include "spectral/expand.h"
#include "spectral/grid_error.h"
#include "spectral/half_bits.h"

namespace spectex {

namespace {

// XYZ weights of a reflectance on the bins under a light (the perfect reflector has Y = 1).
Colorimetry light_on_bins(const Observer& observer, const Spectrum& light,
                          const std::vector<double>& lambda) {
    return Colorimetry::make(observer, light, WavelengthGrid::from_list(lambda),
                             primaries_by_name("srgb"));
}

// The sample's unrounded spectra and their L*a*b* under each light, computed once; measure()
// rounds them to a bit vector and returns the worst ΔE00 per light.
class PrecisionJudge {
  public:
    PrecisionJudge(const PrecisionRequest& req, int stride) : req_(req) {
        if (!req.method) throw Error("precision: no method");
        bins_ = static_cast<size_t>(req.method->bins());
        const std::vector<std::array<uint8_t, 3>> codes = code_sample(stride);
        n_ = codes.size();
        const auto& table = srgb_code_table();
        std::vector<float> r(n_), g(n_), b(n_);
        for (size_t i = 0; i < n_; ++i) {
            r[i] = static_cast<float>(table[codes[i][0]]);
            g[i] = static_cast<float>(table[codes[i][1]]);
            b[i] = static_cast<float>(table[codes[i][2]]);
        }
        spectra_.resize(bins_ * n_);
        req.method->expand_float(r.data(), g.data(), b.data(), n_, spectra_.data(), n_);
        W_.resize(static_cast<Eigen::Index>(3 * req.lights.size()),
                  static_cast<Eigen::Index>(bins_));
        for (size_t j = 0; j < req.lights.size(); ++j) {
            const Colorimetry c = light_on_bins(req.observer, req.lights[j], req.method->lambda());
            lights_.push_back({req.lights[j].name, c.white_xyz, {}});
            W_.middleRows(static_cast<Eigen::Index>(3 * j), 3) = c.W;
        }
        // The unrounded colours' L*a*b* under each light, once.
        const Eigen::MatrixXd xyz = W_ * plane_matrix(spectra_.data(), n_, n_);
        for (size_t j = 0; j < lights_.size(); ++j) {
            auto& l = lights_[j];
            l.ref.resize(n_);
            for (size_t i = 0; i < n_; ++i)
                l.ref[i] = lab_from_xyz(
                    xyz.block(static_cast<Eigen::Index>(3 * j), static_cast<Eigen::Index>(i), 3, 1),
                    l.white);
        }
    }

    size_t colours() const { return n_; }
    size_t bins() const { return bins_; }
    std::vector<std::string> names() const {
        std::vector<std::string> v;
        for (const auto& l : lights_) v.push_back(l.name);
        return v;
    }

    // Worst ΔE00 per light of the sample rounded to `bits`; *full: the colours its grids could not
    // hold, rounded at full precision.
    std::vector<double> measure(const std::vector<int>& bits, size_t* full = nullptr) const {
        constexpr size_t kChunk = 2048;
        const size_t chunks = (n_ + kChunk - 1) / kChunk;
        std::vector<std::vector<double>> worst(chunks, std::vector<double>(lights_.size(), 0.0));
        std::vector<size_t> widened(chunks, 0);
        TaskPool::shared().parallel_for(chunks, std::max(1, req_.threads), [&](size_t c) {
            const size_t i0 = c * kChunk, len = std::min(kChunk, n_ - i0);
            std::vector<uint16_t> h(bins_ * len);
            widened[c] = round_spectra_to_bits(spectra_.data() + i0, n_, len, bins_,
                                               req_.rgb_weight, bits, h.data(), len);
            std::vector<float> back(bins_ * len);
            half_to_floats(h.data(), back.data(), h.size());
            const Eigen::MatrixXd xyz = W_ * plane_matrix(back.data(), len, len);
            for (size_t j = 0; j < lights_.size(); ++j) {
                const auto& l = lights_[j];
                double& w = worst[c][j];
                for (size_t i = 0; i < len; ++i) {
                    const Lab lab = lab_from_xyz(xyz.block(static_cast<Eigen::Index>(3 * j),
                                                           static_cast<Eigen::Index>(i), 3, 1),
                                                 l.white);
                    w = std::max(w, ciede2000(l.ref[i0 + i], lab));
                }
            }
        });
        std::vector<double> out(lights_.size(), 0.0);
        for (const auto& w : worst)
            for (size_t j = 0; j < out.size(); ++j) out[j] = std::max(out[j], w[j]);
        if (full) *full = std::accumulate(widened.begin(), widened.end(), size_t{0});
        return out;
    }

  private:
    struct Light {
        std::string name;
        Eigen::Vector3d white;
        std::vector<Lab> ref;
    };

    // bins x n, bin k of colour i at s[k * stride + i].
    Eigen::MatrixXd plane_matrix(const float* s, size_t stride, size_t n) const {
        Eigen::MatrixXd m(static_cast<Eigen::Index>(bins_), static_cast<Eigen::Index>(n));
        for (size_t k = 0; k < bins_; ++k)
            for (size_t i = 0; i < n; ++i)
                m(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(i)) = s[k * stride + i];
        return m;
    }

    const PrecisionRequest& req_;
    size_t bins_ = 0, n_ = 0;
    std::vector<float> spectra_;  // bin k of colour i at k * n_ + i
    std::vector<Light> lights_;
    Eigen::MatrixXd W_;  // 3·lights x bins: the XYZ weights of every light, stacked
};

// The share of the budget the search holds its coarser sample to (the rest is for the colours
// between its codes).
constexpr double kSearchShare = 0.9;
// The most colours of a sample that a bit vector may leave to full precision: a pixel whose
// colour the coarser grids cannot hold is stored with all bits, so bits that leave many such
// pixels save little.
constexpr double kMaxFullShare = 0.005;

double worst_of(const std::vector<double>& v) {
    return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
}

}  // namespace

size_t expand_half_bits(const SpectralMethod& method, const float* r, const float* g,
                        const float* b, size_t n, uint16_t* out, size_t plane_stride,
                        const std::vector<float>* rgb_weight, const std::vector<int>& bits) {
    if (std::all_of(bits.begin(), bits.end(), [](int k) { return k >= 10; })) {
        method.expand_half(r, g, b, n, out, plane_stride, rgb_weight);
        return 0;
    }
    // Blocks small enough for their float spectra to stay in cache while they are rounded.
    constexpr size_t kBlock = 256;
    const size_t bins = static_cast<size_t>(method.bins());
    std::vector<float> spectra(bins * kBlock);
    size_t widened = 0;
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        method.expand_float(r + i0, g + i0, b + i0, len, spectra.data(), kBlock);
        widened += round_spectra_to_bits(spectra.data(), kBlock, len, bins, rgb_weight, bits,
                                         out + i0, plane_stride);
    }
    return widened;
}

size_t expand_half_premultiplied(const SpectralMethod& method, const float* r, const float* g,
                                 const float* b, const float* alpha, size_t n, uint16_t* out,
                                 size_t plane_stride, const std::vector<float>* rgb_weight,
                                 const std::vector<int>& bits) {
    constexpr size_t kBlock = 256;
    const size_t bins = static_cast<size_t>(method.bins());
    const bool full = std::all_of(bits.begin(), bits.end(), [](int k) { return k >= 10; });
    std::vector<float> spectra(bins * kBlock);
    size_t widened = 0;
    for (size_t i0 = 0; i0 < n; i0 += kBlock) {
        const size_t len = std::min(kBlock, n - i0);
        expand_float_premultiplied(method, r + i0, g + i0, b + i0, alpha + i0, len, spectra.data(),
                                   kBlock);
        if (full)
            round_spectra_to_half(spectra.data(), kBlock, len, bins, rgb_weight, out + i0,
                                  plane_stride);
        else
            widened += round_spectra_to_bits(spectra.data(), kBlock, len, bins, rgb_weight, bits,
                                             out + i0, plane_stride);
    }
    return widened;
}

void expand_float_premultiplied(const SpectralMethod& method, const float* r, const float* g,
                                const float* b, const float* alpha, size_t n, float* out,
                                size_t plane_stride) {
    method.expand_float(r, g, b, n, out, plane_stride);
    for (size_t k = 0; k < static_cast<size_t>(method.bins()); ++k) {
        float* p = out + k * plane_stride;
        for (size_t i = 0; i < n; ++i) p[i] *= alpha[i];
    }
}

std::vector<double> bin_visibility(const Observer& observer, const std::vector<Spectrum>& lights,
                                   const std::vector<double>& lambda) {
    std::vector<double> vis(lambda.size(), 0.0);
    for (const Spectrum& l : lights) {
        const Colorimetry c = light_on_bins(observer, l, lambda);
        const double peak = c.W.cwiseAbs().maxCoeff();
        if (!(peak > 0)) continue;
        for (size_t k = 0; k < lambda.size(); ++k)
            vis[k] = std::max(vis[k],
                              c.W.col(static_cast<Eigen::Index>(k)).cwiseAbs().maxCoeff() / peak);
    }
    return vis;
}

PrecisionChoice measure_precision(const PrecisionRequest& req, const std::vector<int>& bits) {
    const PrecisionJudge judge(req, req.stride);
    PrecisionChoice c;
    c.bits = bits;
    c.light = judge.names();
    c.worst_de = judge.measure(bits);
    c.colours = judge.colours();
    c.evaluations = 1;
    return c;
}

PrecisionChoice choose_precision(const PrecisionRequest& req) {
    if (!(req.max_de > 0) || !std::isfinite(req.max_de))
        throw Error("precision budget must be a positive ΔE00");
    // The search measures a sample with half the codes per axis (an eighth of the colours) against
    // 90 % of the budget; the bits it finds are then measured on the request's sample, and the
    // search's last steps undone while they are over the budget there.
    const PrecisionJudge fine(req, req.stride);
    const PrecisionJudge coarse(req, std::min(255, 2 * req.stride));
    const double search_de = kSearchShare * req.max_de;
    const size_t bins = fine.bins();
    const std::vector<double> vis = bin_visibility(req.observer, req.lights, req.method->lambda());
    auto rule = [&](int offset) {
        std::vector<int> bits(bins);
        for (size_t k = 0; k < bins; ++k) {
            const double v = vis[k] > 0 ? 10 + std::log2(vis[k]) + offset : 0;
            bits[k] = std::clamp(static_cast<int>(std::ceil(v - 1e-9)), kMinMantissaBits, 10);
        }
        return bits;
    };
    PrecisionChoice c;
    c.light = fine.names();
    c.colours = fine.colours();
    // Within the budget, and with few colours that the grids cannot hold (those are stored at
    // full precision: bits that the file would pay for anyway).
    auto within = [&](const PrecisionJudge& j, const std::vector<int>& bits, double budget,
                      std::vector<double>* de = nullptr) {
        size_t full_colours = 0;
        std::vector<double> d = j.measure(bits, &full_colours);
        ++c.evaluations;
        const bool ok =
            worst_of(d) <= budget &&
            static_cast<double>(full_colours) <= kMaxFullShare * static_cast<double>(j.colours());
        if (de) *de = std::move(d);
        return ok;
    };
    const std::vector<int> full(bins, 10);
    std::vector<int> best = full;
    // Each step that lowered the bits from the rule's start: (bin, or bins.size() for a whole
    // offset step) with the bits before it, undone in reverse if the final measure is over.
    std::vector<std::vector<int>> history;
    if (within(coarse, full, search_de)) {
        // The rule's offsets from 0 down while within budget (fewer bits everywhere each step);
        // if even the rule (offset 0) is over, the offsets above it, up to all 10.
        int offset = 0;
        if (within(coarse, rule(0), search_de)) {
            best = rule(0);
            while (offset > -10 && within(coarse, rule(offset - 1), search_de)) {
                history.push_back(best);
                best = rule(--offset);
            }
        } else {
            for (int up = 1; up <= 10; ++up)
                if (within(coarse, rule(up), search_de)) {
                    best = rule(up);
                    break;
                }
        }
        // Then one bit at a time, least visible bins first (ties: the lower bin).
        std::vector<size_t> order(bins);
        std::iota(order.begin(), order.end(), size_t{0});
        std::stable_sort(order.begin(), order.end(),
                         [&](size_t a, size_t b) { return vis[a] < vis[b]; });
        for (size_t k : order) {
            if (best[k] <= kMinMantissaBits) continue;
            std::vector<int> bits = best;
            --bits[k];
            if (within(coarse, bits, search_de)) history.push_back(best), best = bits;
        }
    }
    std::vector<double> de;
    while (!within(fine, best, req.max_de, &de)) {
        if (history.empty()) {
            best = full;
            de = fine.measure(full);
            ++c.evaluations;
            break;
        }
        best = history.back();
        history.pop_back();
    }
    c.bits = best;
    c.worst_de = de;
    return c;
}

std::string format_precision_bits(const std::vector<int>& bits) {
    std::string s;
    for (int b : bits) s += (s.empty() ? "" : " ") + std::to_string(b);
    return s;
}

std::vector<int> parse_precision_bits(const std::string& text, size_t bins) {
    std::vector<int> bits;
    size_t i = 0;
    while (i < text.size()) {
        if (text[i] == ' ') {
            ++i;
            continue;
        }
        size_t j = i;
        while (j < text.size() && text[j] != ' ') ++j;
        const std::string word = text.substr(i, j - i);
        if (word.size() > 2 || word.find_first_not_of("0123456789") != std::string::npos ||
            std::stoi(word) > 10)
            throw Error("precision bits '" + one_line(word) + "' is not a whole number 0 to 10");
        bits.push_back(std::stoi(word));
        i = j;
    }
    if (bits.size() != bins)
        throw Error("precision bits list " + std::to_string(bits.size()) + " bins, the file has " +
                    std::to_string(bins));
    return bits;
}

double kept_fraction(const std::vector<int>& bits) {
    if (bits.empty()) return 1.0;
    return std::accumulate(bits.begin(), bits.end(), 0.0) /
           (10.0 * static_cast<double>(bits.size()));
}

}  // namespace spectex
