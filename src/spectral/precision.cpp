#include "spectral/precision.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
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

// The colour of a file's spectra as a renderer sees it (spectral/grid_error.h): the bins
// reconstructed linearly at 1 nm, end values held, over 360-830 nm (clipped to the observer's
// table), integrated with the observer under the light. W is 3 x bins; white is the perfect
// reflector's XYZ (Y = 1).
struct RendererWeights {
    std::string name;
    Eigen::MatrixXd W;
    Eigen::Vector3d white;
};
RendererWeights renderer_weights(const Observer& observer, const Spectrum& light,
                                 const std::vector<double>& lambda) {
    const WavelengthGrid fine = observed_renderer_grid(observer);
    const LightWeights lw = light_weights(observer, light, fine);
    RendererWeights rw;
    rw.name = light.name;
    rw.W = lw.W * reconstruction_matrix(lambda, fine.lambda, Reconstruction::Linear);
    rw.white = lw.white;
    return rw;
}

// The request's codes (PrecisionRequest::codes), or IEC 61966-2-1's in float when it has none.
std::vector<float> code_values(const PrecisionRequest& req) {
    if (!req.codes.empty()) {
        if (req.codes.size() != 3 * 256) throw Error("precision: the codes are not 3 x 256 values");
        return req.codes;
    }
    std::vector<float> v(3 * 256);
    const auto& table = srgb_code_table();
    for (size_t i = 0; i < v.size(); ++i) v[i] = static_cast<float>(table[i / 3]);
    return v;
}

// The sample's unrounded spectra and their L*a*b* under each light, computed once; measure()
// rounds them to a bit vector and returns the worst ΔE00 per light.
class PrecisionJudge {
  public:
    PrecisionJudge(const PrecisionRequest& req, const std::vector<std::array<uint8_t, 3>>& codes)
        : req_(req) {
        if (!req.method) throw Error("precision: no method");
        bins_ = static_cast<size_t>(req.method->bins());
        n_ = codes.size();
        const std::vector<float> table = code_values(req);
        std::vector<float> r(n_), g(n_), b(n_);
        for (size_t i = 0; i < n_; ++i) {
            r[i] = table[3 * codes[i][0]];
            g[i] = table[3 * codes[i][1] + 1];
            b[i] = table[3 * codes[i][2] + 2];
        }
        spectra_.resize(bins_ * n_);
        req.method->expand_float(r.data(), g.data(), b.data(), n_, spectra_.data(), n_);
        W_.resize(static_cast<Eigen::Index>(3 * req.lights.size()),
                  static_cast<Eigen::Index>(bins_));
        for (size_t j = 0; j < req.lights.size(); ++j) {
            const RendererWeights c =
                renderer_weights(req.observer, req.lights[j], req.method->lambda());
            lights_.push_back({req.lights[j].name, c.white, {}});
            W_.middleRows(static_cast<Eigen::Index>(3 * j), 3) = c.W;
        }
        // The reference colours' L*a*b* under each light, once: the method's own spectrum at 1 nm
        // when the request has it, else the unrounded spectra on the file's grid.
        Eigen::MatrixXd xyz;
        if (const SpectralMethod* ref = req.reference) {
            const size_t rb = static_cast<size_t>(ref->bins());
            std::vector<float> rs(rb * n_);
            ref->expand_float(r.data(), g.data(), b.data(), n_, rs.data(), n_);
            Eigen::MatrixXd Wr(static_cast<Eigen::Index>(3 * req.lights.size()),
                               static_cast<Eigen::Index>(rb));
            for (size_t j = 0; j < req.lights.size(); ++j)
                Wr.middleRows(static_cast<Eigen::Index>(3 * j), 3) =
                    renderer_weights(req.observer, req.lights[j], ref->lambda()).W;
            xyz = Wr * plane_matrix(rs.data(), n_, n_, rb);
        } else {
            xyz = W_ * plane_matrix(spectra_.data(), n_, n_, bins_);
        }
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
            const Eigen::MatrixXd xyz = W_ * plane_matrix(back.data(), len, len, bins_);
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
    static Eigen::MatrixXd plane_matrix(const float* s, size_t stride, size_t n, size_t bins) {
        Eigen::MatrixXd m(static_cast<Eigen::Index>(bins), static_cast<Eigen::Index>(n));
        for (size_t k = 0; k < bins; ++k)
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

// Every one of the 16,777,216 8-bit sRGB codes, expanded and rounded to a bit vector exactly as a
// bake rounds them (expand_float, round_spectra_to_bits with the request's weights): the worst
// ΔE00 per light against the reference (the method at 1 nm; without one, the unrounded spectra),
// and the colours above a threshold. Streams 256
// colours at a time (one blue axis), so it holds no more than a few blocks of spectra per thread.
class CubeJudge {
  public:
    explicit CubeJudge(const PrecisionRequest& req) : req_(req) {
        bins_ = static_cast<size_t>(req.method->bins());
        const size_t L = req.lights.size();
        Wt_.resize(static_cast<Eigen::Index>(bins_), static_cast<Eigen::Index>(3 * L));
        for (size_t j = 0; j < L; ++j) {
            const RendererWeights c =
                renderer_weights(req.observer, req.lights[j], req.method->lambda());
            Wt_.middleCols(static_cast<Eigen::Index>(3 * j), 3) = c.W.transpose().cast<float>();
            white_.push_back(c.white);
        }
        if (const SpectralMethod* ref = req.reference) {
            ref_bins_ = static_cast<size_t>(ref->bins());
            Eigen::MatrixXd Wr(static_cast<Eigen::Index>(3 * L),
                               static_cast<Eigen::Index>(ref_bins_));
            for (size_t j = 0; j < L; ++j)
                Wr.middleRows(static_cast<Eigen::Index>(3 * j), 3) =
                    renderer_weights(req.observer, req.lights[j], ref->lambda()).W;
            // The reference's colours straight from its table when it has the shortcut (3·lights
            // values a colour instead of its 471 bins); else expanded and integrated.
            ref_colours_ = ref->weighted(Wr);
            if (!ref_colours_) WtRef_ = Wr.transpose().cast<float>();
        }
    }

    struct Result {
        std::vector<double> worst;  // per light, over every code
        // Per light, the code of that worst (0xRRGGBB; the lowest of equal ones).
        std::vector<uint32_t> worst_code;
        // Codes whose ΔE00 under some light exceeds the threshold (the cap's worst), by code.
        std::vector<uint32_t> hard;
        size_t full = 0;  // codes the grids could not hold (stored at full precision)
    };

    // `floor`: per light, a figure below the cube's worst (a sample's worst, lowered a little):
    // colours whose bound stays under it and under hard_de are not evaluated exactly.
    Result measure(const std::vector<int>& bits, const std::vector<double>& floor, double hard_de,
                   size_t max_hard) const {
        constexpr size_t kRowsPerTask = 16;  // 16 (r, g) pairs of 256 blues: 4,096 colours
        const size_t tasks = 65536 / kRowsPerTask, L = white_.size();
        struct Part {
            std::vector<double> worst;
            std::vector<uint32_t> worst_code;
            std::vector<std::pair<double, uint32_t>> hard;
            size_t full = 0;
        };
        std::vector<Part> parts(tasks);
        const std::vector<float> lin = code_values(req_);
        TaskPool::shared().parallel_for(tasks, std::max(1, req_.threads), [&](size_t t) {
            Part& p = parts[t];
            p.worst.assign(L, 0.0);
            p.worst_code.assign(L, 0);
            std::vector<float> r(256), g(256), b(256), s(bins_ * 256), back(bins_ * 256);
            std::vector<uint16_t> h(bins_ * 256);
            std::vector<float> sr(ref_colours_ ? 3 * L * 256 : ref_bins_ * 256);
            for (size_t i = 0; i < 256; ++i) b[i] = lin[3 * i + 2];
            for (size_t row = t * kRowsPerTask; row < (t + 1) * kRowsPerTask; ++row) {
                std::fill(r.begin(), r.end(), lin[3 * (row >> 8)]);
                std::fill(g.begin(), g.end(), lin[3 * (row & 255) + 1]);
                req_.method->expand_float(r.data(), g.data(), b.data(), 256, s.data(), 256);
                p.full += round_spectra_to_bits(s.data(), 256, 256, bins_, req_.rgb_weight, bits,
                                                h.data(), 256);
                half_to_floats(h.data(), back.data(), h.size());
                // Rounded minus unrounded: exact in float (the two are within a factor of 2).
                for (size_t k = 0; k < back.size(); ++k) back[k] -= s[k];
                const Eigen::Map<const Eigen::MatrixXf> S(s.data(), 256,
                                                          static_cast<Eigen::Index>(bins_));
                const Eigen::Map<const Eigen::MatrixXf> D(back.data(), 256,
                                                          static_cast<Eigen::Index>(bins_));
                // X0: the reference; X0 + dX: the file as a renderer sees it. Without a reference
                // the reference is the unrounded spectra on the file's grid.
                Eigen::MatrixXf X0 = S * Wt_, dX = D * Wt_;
                if (ref_colours_) {
                    ref_colours_->expand_float(r.data(), g.data(), b.data(), 256, sr.data(), 256);
                    const Eigen::Map<const Eigen::MatrixXf> XR(sr.data(), 256,
                                                               static_cast<Eigen::Index>(3 * L));
                    dX += X0 - XR;
                    X0 = XR;
                } else if (ref_bins_ > 0) {
                    req_.reference->expand_float(r.data(), g.data(), b.data(), 256, sr.data(), 256);
                    const Eigen::Map<const Eigen::MatrixXf> SR(
                        sr.data(), 256, static_cast<Eigen::Index>(ref_bins_));
                    const Eigen::MatrixXf XR = SR * WtRef_;
                    dX += X0 - XR;
                    X0 = XR;
                }
                for (size_t j = 0; j < L; ++j) {
                    const Eigen::Index c0 = static_cast<Eigen::Index>(3 * j);
                    for (Eigen::Index i = 0; i < 256; ++i) {
                        const Eigen::Vector3d x0(X0(i, c0), X0(i, c0 + 1), X0(i, c0 + 2));
                        const Eigen::Vector3d dx(dX(i, c0), dX(i, c0 + 1), dX(i, c0 + 2));
                        if (dx.isZero(0.0)) continue;
                        const Lab a = lab_from_xyz_fast(x0, white_[j]),
                                  c = lab_from_xyz_fast(x0 + dx, white_[j]);
                        // Two bounds before the exact figure: sqrt(4.5)·ΔE76 (ΔE00 never exceeds
                        // it; a few operations), then ciede2000_upper_bound (tighter for
                        // saturated colours, no trigonometry).
                        const double skip = std::min(std::max(p.worst[j], floor[j]), hard_de);
                        const double de76_2 = (a.L - c.L) * (a.L - c.L) +
                                              (a.a - c.a) * (a.a - c.a) + (a.b - c.b) * (a.b - c.b);
                        if (4.5 * de76_2 <= skip * skip || ciede2000_upper_bound(a, c) <= skip)
                            continue;
                        const double de = ciede2000(a, c);
                        const uint32_t code = static_cast<uint32_t>((row << 8) | size_t(i));
                        if (de > p.worst[j]) {
                            p.worst[j] = de;
                            p.worst_code[j] = code;
                        }
                        if (de > hard_de && max_hard > 0) {
                            p.hard.emplace_back(de, code);
                            if (p.hard.size() > 2 * max_hard) keep_worst(p.hard, max_hard);
                        }
                    }
                }
            }
        });
        Result out;
        out.worst.assign(L, 0.0);
        out.worst_code.assign(L, 0);
        std::vector<std::pair<double, uint32_t>> hard;
        for (const Part& p : parts) {  // in code order: a tie keeps the lower code
            for (size_t j = 0; j < L; ++j)
                if (p.worst[j] > out.worst[j]) {
                    out.worst[j] = p.worst[j];
                    out.worst_code[j] = p.worst_code[j];
                }
            hard.insert(hard.end(), p.hard.begin(), p.hard.end());
            out.full += p.full;
        }
        keep_worst(hard, max_hard);
        for (const auto& e : hard) out.hard.push_back(e.second);
        std::sort(out.hard.begin(), out.hard.end());
        out.hard.erase(std::unique(out.hard.begin(), out.hard.end()), out.hard.end());
        return out;
    }

  private:
    // The `cap` largest (ΔE00, code) pairs, in any order (ties: the lower code).
    static void keep_worst(std::vector<std::pair<double, uint32_t>>& v, size_t cap) {
        if (v.size() <= cap) return;
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(cap), v.end(),
                         [](const auto& x, const auto& y) {
                             return x.first != y.first ? x.first > y.first : x.second < y.second;
                         });
        v.resize(cap);
    }

    const PrecisionRequest& req_;
    size_t bins_ = 0, ref_bins_ = 0;
    Eigen::MatrixXf Wt_;     // bins x 3·lights: every light's renderer weights, side by side
    Eigen::MatrixXf WtRef_;  // the same on the reference's 1 nm grid (without the shortcut)
    std::shared_ptr<const SpectralMethod> ref_colours_;  // the reference's weighted shortcut
    std::vector<Eigen::Vector3d> white_;
};

// The share of the budget the search holds its coarser sample to (the rest is for the colours
// between its codes).
constexpr double kSearchShare = 0.9;
// The most colours of a sample that a bit vector may leave to full precision: a pixel whose
// colour the coarser grids cannot hold is stored with all bits, so bits that leave many such
// pixels save little.
constexpr double kMaxFullShare = 0.005;

// The cube judge's colours that join the sample after a pass over the budget: those above this
// share of the budget, at most kMaxHardColours of the worst.
constexpr double kHardShare = 0.7;
// The cube judge evaluates exactly only the colours that could beat this share of the sample's
// worst (which the cube holds: its figure in float is within kCubeMargin of it).
constexpr double kFloorShare = 0.999;
// The cube judge sums in float (its XYZ and their differences, a few hundred terms each: a
// relative error of order 1e-6); the figure it records, and the one it holds to the budget, is
// raised by this factor. Tests compare the recorded figure with double-precision ones on a
// million codes (precision_test.cpp) and budget_cube.py on every code.
constexpr double kCubeMargin = 1.0001;
constexpr size_t kMaxHardColours = 50000;
// A pass that wants the worst alone: no colour is hard.
constexpr double kNoHardColours = std::numeric_limits<double>::infinity();

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
                                  plane_stride, alpha + i0);
        else
            widened += round_spectra_to_bits(spectra.data(), kBlock, len, bins, rgb_weight, bits,
                                             out + i0, plane_stride, alpha + i0);
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
    // Each bin's XYZ weight under each light, the light dark beyond its table (a grid may reach
    // past a light's table: 380:830 against A's 300-780), relative to the light's largest.
    const WavelengthGrid grid = WavelengthGrid::from_list(lambda);
    const std::vector<double> x = observer.x.sample(grid), y = observer.y.sample(grid),
                              z = observer.z.sample(grid);
    std::vector<double> vis(lambda.size(), 0.0), w(lambda.size());
    for (const Spectrum& l : lights) {
        double peak = 0;
        for (size_t k = 0; k < lambda.size(); ++k) {
            const double e = l.at_or_dark(lambda[k]) * grid.weight[k];
            w[k] = std::max({std::abs(e * x[k]), std::abs(e * y[k]), std::abs(e * z[k])});
            peak = std::max(peak, w[k]);
        }
        if (!(peak > 0)) continue;
        for (size_t k = 0; k < lambda.size(); ++k) vis[k] = std::max(vis[k], w[k] / peak);
    }
    return vis;
}

PrecisionChoice measure_precision(const PrecisionRequest& req, const std::vector<int>& bits) {
    const PrecisionJudge judge(req, code_sample(req.stride));
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
    std::vector<std::array<uint8_t, 3>> sample = code_sample(req.stride);
    auto fine = std::make_unique<PrecisionJudge>(req, sample);
    const PrecisionJudge coarse(req, code_sample(std::min(255, 2 * req.stride)));
    const double search_de = kSearchShare * req.max_de;
    const size_t bins = fine->bins();
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
    c.light = fine->names();
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
    // With the method at 1 nm as the reference, the grid alone may be over the budget: then no
    // bits are, and all 10 are kept without a search (the recorded worst says by how much).
    const bool reachable = within(*fine, full, req.max_de);
    if (reachable && within(coarse, full, search_de)) {
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
    // Undoes the search's steps, last first, while `judge` finds the bits over the budget (all 10
    // when none is left). False when nothing was undone.
    auto step_back = [&] {
        best = history.empty() ? full : history.back();
        if (!history.empty()) history.pop_back();
    };
    auto undo_while_over = [&](const PrecisionJudge& judge) {
        bool undone = false;
        while (best != full && !within(judge, best, req.max_de)) step_back(), undone = true;
        return undone;
    };
    if (reachable) undo_while_over(*fine);
    // Then every 8-bit colour: while some colour between the sample's codes is over the budget,
    // the colours above kHardShare of it join the sample and the steps are undone again on it.
    // Each pass either ends or undoes at least one step, so this ends, at all 10 bits at worst.
    const CubeJudge cube(req);
    bool full_checked = false;
    std::vector<uint32_t> added;
    CubeJudge::Result res;
    for (;;) {
        std::vector<double> floor;
        for (double w : fine->measure(best)) floor.push_back(w * kFloorShare);
        // All 10 bits is the last answer there is: only its worst is wanted, not the colours over
        // the budget (every colour would be evaluated exactly when the grid alone is over it).
        const bool last = best == full;
        res = cube.measure(best, floor, last ? kNoHardColours : kHardShare * req.max_de,
                           last ? 0 : kMaxHardColours);
        ++c.evaluations;
        if (worst_of(res.worst) * kCubeMargin <= req.max_de || last) break;
        if (!full_checked) {
            // Over on the cube: if even all 10 bits are (the grid's own error), stop there rather
            // than undo the search one whole-cube pass at a time.
            full_checked = true;
            CubeJudge::Result at_full = cube.measure(full, floor, kNoHardColours, 0);
            ++c.evaluations;
            if (worst_of(at_full.worst) * kCubeMargin > req.max_de) {
                best = full;
                res = std::move(at_full);
                break;
            }
        }
        size_t fresh = 0;
        for (uint32_t code : res.hard)
            if (!std::binary_search(added.begin(), added.end(), code)) {
                sample.push_back({{static_cast<uint8_t>(code >> 16),
                                   static_cast<uint8_t>(code >> 8), static_cast<uint8_t>(code)}});
                ++fresh;
            }
        added.insert(added.end(), res.hard.begin(), res.hard.end());
        std::sort(added.begin(), added.end());
        added.erase(std::unique(added.begin(), added.end()), added.end());
        if (fresh > 0) fine = std::make_unique<PrecisionJudge>(req, sample);
        if (!undo_while_over(*fine)) {
            // The sample holds the cube's worst colours and still finds the bits within (its
            // arithmetic is double, the cube's float): one more step back.
            step_back();
        }
    }
    c.bits = best;
    c.worst_de.clear();
    for (double w : res.worst) c.worst_de.push_back(w * kCubeMargin);
    c.worst_code = res.worst_code;
    c.colours = size_t(1) << 24;
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

std::string format_de_up(double de) {
    if (!(de > 0) || !std::isfinite(de)) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%g", de);
        return buf;
    }
    const double scale = std::pow(10.0, 2 - static_cast<int>(std::floor(std::log10(de))));
    // The smallest 3-digit figure at or above de (a product that lands on a whole number stays).
    double up = std::ceil(de * scale * (1 - 1e-15)) / scale;
    while (up < de) up += 1 / scale;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", up);
    return buf;
}

double kept_fraction(const std::vector<int>& bits) {
    if (bits.empty()) return 1.0;
    return std::accumulate(bits.begin(), bits.end(), 0.0) /
           (10.0 * static_cast<double>(bits.size()));
}

}  // namespace spectex
