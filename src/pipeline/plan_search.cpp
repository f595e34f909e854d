#include "pipeline/plan_search.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <set>

#include "base/error.h"
#include "base/task_pool.h"
#include "spectral/basis_fit.h"
#include "spectral/ciede2000.h"
#include "spectral/colorimetry.h"

namespace spectex {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kSearchStride = 17;
constexpr int kMaxStartBins = 64;    // removal from a start of n bins costs about n²/2 trials
constexpr int kMaxSearchBins = 160;  // when no uniform candidate meets the budget  // 0, 17, ...,
                                     // 238 and 255: 16 values per axis, 4,096 colours

// What every trial shares: the colours, their reference L*a*b* under each light.
struct SearchContext {
    const PlanSpec& spec;
    const Observer& observer;
    const Spectrum& exact_under;
    const WavelengthGrid& fine;
    const std::vector<LightWeights>& lights;
    Eigen::Matrix3Xd rgb;               // linear RGB, the most saturated colours first
    std::vector<std::vector<Lab>> ref;  // per light, per colour

    SearchContext(const PlanSpec& s, const Observer& o, const Spectrum& e, const WavelengthGrid& f,
                  const std::vector<LightWeights>& l, const Eigen::MatrixXd& reference)
        : spec(s), observer(o), exact_under(e), fine(f), lights(l) {
        auto codes = code_sample(kSearchStride);
        // Saturated colours carry the largest errors: trying them first lets a trial stop early
        // once it is worse than the best trial so far.
        std::stable_sort(codes.begin(), codes.end(), [](const auto& a, const auto& b) {
            auto chroma = [](const std::array<uint8_t, 3>& c) {
                return std::max({c[0], c[1], c[2]}) - std::min({c[0], c[1], c[2]});
            };
            return chroma(a) > chroma(b);
        });
        const auto& t = srgb_code_table();
        rgb.resize(3, static_cast<Eigen::Index>(codes.size()));
        for (size_t i = 0; i < codes.size(); ++i)
            rgb.col(static_cast<Eigen::Index>(i)) << t[codes[i][0]], t[codes[i][1]], t[codes[i][2]];
        for (const auto& lw : lights) {
            const Eigen::Matrix3d M = lw.W * reference;
            std::vector<Lab> labs(codes.size());
            for (Eigen::Index i = 0; i < rgb.cols(); ++i)
                labs[static_cast<size_t>(i)] = lab_from_xyz(M * rgb.col(i), lw.white);
            ref.push_back(std::move(labs));
        }
    }

    // The worst ΔE00 of `grid` over the colours and lights; stops as soon as it exceeds `bound`
    // (the result is then only known to be above it). +inf when no exact basis exists on the grid.
    double error(const WavelengthGrid& grid, double bound = kInf) const {
        Eigen::MatrixXd B;
        try {
            FitRequest req{Colorimetry::make(observer, exact_under, grid,
                                             primaries_by_name(spec.method.fit.primaries)),
                           spec.method.fit.objective, false};
            const Basis b = fit_basis(req).basis;
            B.resize(static_cast<Eigen::Index>(b.size()), 3);
            for (size_t k = 0; k < b.size(); ++k)
                B.row(static_cast<Eigen::Index>(k)) << b.r[k], b.g[k], b.b[k];
        } catch (const Error&) {
            return kInf;
        }
        const Eigen::MatrixXd R =
            reconstruction_matrix(grid.lambda, fine.lambda, spec.reconstruction);
        double worst = 0;
        for (size_t j = 0; j < lights.size(); ++j) {
            const Eigen::Matrix3d M = lights[j].W * R * B;
            for (Eigen::Index i = 0; i < rgb.cols(); ++i) {
                const double de = ciede2000(ref[j][static_cast<size_t>(i)],
                                            lab_from_xyz(M * rgb.col(i), lights[j].white));
                if (!(de <= worst)) worst = std::isnan(de) ? kInf : de;
                if (worst > bound) return worst;
            }
        }
        return worst;
    }
};

}  // namespace

double search_error(const PlanSpec& spec, const Observer& observer, const Spectrum& exact_under,
                    const WavelengthGrid& fine, const std::vector<LightWeights>& lights,
                    const Eigen::MatrixXd& reference, const WavelengthGrid& grid) {
    return SearchContext(spec, observer, exact_under, fine, lights, reference).error(grid);
}

NonuniformSearch search_nonuniform(const PlanSpec& spec, const Observer& observer,
                                   const Spectrum& exact_under, const WavelengthGrid& fine,
                                   const std::vector<LightWeights>& lights,
                                   const Eigen::MatrixXd& reference,
                                   const std::vector<WavelengthGrid>& uniform, int threads,
                                   int trail) {
    const auto t0 = std::chrono::steady_clock::now();
    const SearchContext ctx(spec, observer, exact_under, fine, lights, reference);
    NonuniformSearch out;
    std::atomic<long> trials{0};

    // The bins to beat: the cheapest uniform candidate within the budget on the same colours.
    std::vector<double> uerr(uniform.size());
    TaskPool::shared().parallel_for(uniform.size(), threads, [&](size_t i) {
        uerr[i] = ctx.error(uniform[i]);
        ++trials;
    });
    for (size_t i = 0; i < uniform.size(); ++i)
        if (uerr[i] <= spec.max_de &&
            (out.uniform_bins == 0 || static_cast<int>(uniform[i].size()) < out.uniform_bins))
            out.uniform_bins = static_cast<int>(uniform[i].size());

    // Greedy removal from uniform starts over each range: drop the bin whose loss raises the worst
    // error least, while the grid stays within the budget; the trail keeps the last grids that
    // held.
    std::vector<std::pair<double, double>> ranges = {
        {400, 700}, {380, 780}, {spec.range_start, spec.range_end}};
    std::sort(ranges.begin(), ranges.end());
    ranges.erase(std::unique(ranges.begin(), ranges.end()), ranges.end());
    std::vector<std::pair<WavelengthGrid, double>> starts;  // a grid that holds, and its error
    for (const auto& [lo, hi] : ranges) {
        if (lo < fine.lambda.front() || hi > fine.lambda.back()) continue;
        // The coarsest of 10, 5, 4 and 2.5 nm that holds, and the next finer one (at most
        // kMaxStartBins bins: removal costs bins² trials).
        int found = 0;
        for (double step : {10.0, 5.0, 4.0, 2.5}) {
            WavelengthGrid g = WavelengthGrid::uniform_grid(
                lo, lo + std::floor((hi - lo) / step + 1e-9) * step, step);
            if (static_cast<int>(g.size()) > kMaxStartBins) break;
            ++trials;
            const double e = ctx.error(g);
            if (!(e <= spec.max_de)) {
                if (found == 0) continue;
                break;
            }
            starts.emplace_back(g, e);
            if (++found == 2) break;
        }
    }
    for (const auto& start : starts) {
        // Not a structured binding: lambdas below capture g, which C++17 (clang) does not allow.
        WavelengthGrid g = start.first;
        double err = start.second;
        std::vector<WavelengthGrid> held = {g};
        while (g.size() > 2) {
            std::vector<double> errs(g.size(), kInf);
            std::atomic<double> best{kInf};
            TaskPool::shared().parallel_for(g.size(), threads, [&](size_t i) {
                std::vector<double> l = g.lambda;
                l.erase(l.begin() + static_cast<std::ptrdiff_t>(i));
                errs[i] = ctx.error(WavelengthGrid::from_list(l), best.load());
                double b = best.load();
                while (errs[i] < b && !best.compare_exchange_weak(b, errs[i])) {
                }
                ++trials;
            });
            const size_t pick =
                static_cast<size_t>(std::min_element(errs.begin(), errs.end()) - errs.begin());
            if (!(errs[pick] <= spec.max_de)) break;
            std::vector<double> l = g.lambda;
            l.erase(l.begin() + static_cast<std::ptrdiff_t>(pick));
            g = WavelengthGrid::from_list(l);
            err = errs[pick];
            held.push_back(g);
        }
        if (out.best_bins == 0 || static_cast<int>(g.size()) < out.best_bins) {
            out.best_bins = static_cast<int>(g.size());
            out.best_worst = err;
        }
        // The last grids that held, fewer bins than the cheapest uniform one.
        for (size_t k = held.size() > static_cast<size_t>(trail) + 1
                            ? held.size() - static_cast<size_t>(trail) - 1
                            : 0;
             k < held.size(); ++k)
            if (out.uniform_bins == 0 || static_cast<int>(held[k].size()) < out.uniform_bins)
                out.grids.push_back(held[k]);
    }
    out.trials = trials.load();
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    char buf[320];
    if (out.best_bins > 0 && (out.uniform_bins == 0 || out.best_bins < out.uniform_bins))
        std::snprintf(buf, sizeof buf,
                      "non-uniform search: %d bins within the budget on the search colours (%.3g), "
                      "the cheapest "
                      "uniform grid %d; %ld trials, %.1f s",
                      out.best_bins, out.best_worst, out.uniform_bins, out.trials, out.seconds);
    else if (out.best_bins > 0)
        std::snprintf(buf, sizeof buf,
                      "non-uniform search: none with fewer bins than the cheapest uniform grid "
                      "(%d): the fewest that "
                      "held was %d; %ld trials, %.1f s",
                      out.uniform_bins, out.best_bins, out.trials, out.seconds);
    else
        std::snprintf(buf, sizeof buf,
                      "non-uniform search: no uniform start (10, 5, 4 or 2.5 nm, at most %d bins) "
                      "holds the budget "
                      "on the search colours; %ld trials, %.1f s",
                      kMaxStartBins, out.trials, out.seconds);
    out.note = buf;
    return out;
}

}  // namespace spectex
