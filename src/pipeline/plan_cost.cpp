// What a plan costs (the spectral samples it measures) and the limit on it: the search itself is
// in plan.cpp, this is checked before it starts (by plan, and by bake --wavelengths auto).
#include <algorithm>
#include <cstdio>
#include <string>

#include "base/error.h"
#include "base/text.h"
#include "pipeline/method_table.h"
#include "pipeline/plan.h"

namespace spectex {

namespace {

// The colours a row is measured on: the dense sample's size (stride s: 0, s, 2s, ... and 255 per
// axis), or the texture's cap.
uint64_t colours_per_row(const PlanSpec& spec) {
    if (!spec.texture.empty()) return spec.texture_cap;
    const uint64_t stride = static_cast<uint64_t>(std::max(1, spec.sample_stride));
    const uint64_t axis = 255 / stride + 1 + (255 % stride ? 1 : 0);
    return axis * axis * axis;
}

uint64_t candidate_bins(const PlanSpec& spec) {
    uint64_t bins = 0;
    for (const auto& g : spec.candidates.empty()
                             ? default_candidates(spec.range_start, spec.range_end)
                             : spec.candidates)
        bins += g.size();
    return bins;
}

}  // namespace

uint64_t plan_cost(const PlanSpec& spec) {
    return candidate_bins(spec) * static_cast<uint64_t>(spec.lights.size()) * colours_per_row(spec);
}

void check_plan_cost(const PlanSpec& spec) {
    const uint64_t bins = candidate_bins(spec);
    if (method_row(spec.method.kind).table_axis(spec.method) > 0) {
        const MethodSpec& m = spec.method;
        const uint64_t fine =
            static_cast<uint64_t>(std::max(0.0, spec.range_end - spec.range_start)) + 1;
        check_method_cost(m, bins + fine,
                          std::to_string(bins + fine) +
                              " bins (every candidate grid's and the 1 nm reference's, held "
                              "together)");
    }
    const uint64_t cost = plan_cost(spec);
    if (cost <= kPlanCostLimit) return;
    // The option furthest above its default carries the blame.
    const PlanSpec defaults;
    const uint64_t default_bins = candidate_bins(defaults),
                   default_colours = colours_per_row(defaults);
    const double by_grids = static_cast<double>(bins) / static_cast<double>(default_bins),
                 by_lights = static_cast<double>(spec.lights.size()) / 3.0,
                 by_colours = static_cast<double>(colours_per_row(spec)) /
                              static_cast<double>(default_colours);
    std::string option = "--grids";
    if (by_lights > by_grids && by_lights >= by_colours) option = "--lights";
    if (by_colours > by_grids && by_colours > by_lights)
        option = spec.texture.empty() ? "--sample-stride" : "--texture";
    char figure[32], limit[32];
    std::snprintf(figure, sizeof figure, "%.3g", static_cast<double>(cost));
    std::snprintf(limit, sizeof limit, "%.3g", static_cast<double>(kPlanCostLimit));
    const size_t grids = spec.candidates.empty()
                             ? default_candidates(spec.range_start, spec.range_end).size()
                             : spec.candidates.size();
    throw LimitError(
        option + ": " + std::to_string(grids) + " grid" + (grids == 1 ? "" : "s") + " of " +
        std::to_string(bins) + " bins in all x " + std::to_string(spec.lights.size()) + " light" +
        (spec.lights.size() == 1 ? "" : "s") + " x " + thousands(colours_per_row(spec)) +
        " colours = " + figure + " spectral samples to measure, over the limit of " + limit +
        " (8 times the default table); give coarser or fewer --grids, fewer "
        "--lights or a larger --sample-stride");
}

}  // namespace spectex
