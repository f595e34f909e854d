#include "pipeline/plan_colours.h"

#include <cmath>

#include "base/error.h"
#include "base/text.h"
#include "pipeline/plan_texture.h"
#include "pipeline/table_memo.h"
#include "spectral/srgb_axis.h"

namespace spectex {

PlanScene load_plan_scene(const PlanSpec& spec) {
    const std::string& dir = spec.method.fit.data_dir;
    PlanScene s;
    s.fine = renderer_grid(spec.range_start, spec.range_end);
    s.observer = *observer_table(dir, spec.method.fit.observer);
    for (const auto& name : spec.lights)
        s.lights.push_back(light_weights(s.observer, *illuminant_table(dir, name), s.fine));
    for (size_t j = 0; j < s.lights.size(); ++j) s.lights[j].name = spec.lights[j];
    return s;
}

namespace {

PlanColours cube_sample_colours(const PlanSpec& spec) {
    PlanColours c;
    c.codes = code_sample(spec.sample_stride);
    const auto& t = srgb_code_table();
    for (const auto& code : c.codes) {
        c.sr.push_back(static_cast<float>(t[code[0]]));
        c.sg.push_back(static_cast<float>(t[code[1]]));
        c.sb.push_back(static_cast<float>(t[code[2]]));
    }
    c.text = thousands(c.codes.size()) + " colours (every " + std::to_string(spec.sample_stride) +
             "th 8-bit sRGB code and 255 per axis, the cube's faces included)";
    return c;
}

PlanColours texture_sample_colours(const PlanSpec& spec) {
    const TextureColours tc = texture_colours(spec.texture, spec.method.fit.data_dir, spec.config,
                                              spec.colorspace, spec.max_pixels, spec.texture_cap);
    if (tc.rgb.empty())
        throw Error(spec.texture + ": no pixel with alpha above 0: no colour to plan for");
    PlanColours c;
    for (const auto& rgb : tc.rgb) {
        c.sr.push_back(rgb[0]);
        c.sg.push_back(rgb[1]);
        c.sb.push_back(rgb[2]);
        auto code = [](float v) {
            return static_cast<uint8_t>(std::lround(255.0 * srgb_encode(v)));
        };
        c.codes.push_back({{code(rgb[0]), code(rgb[1]), code(rgb[2])}});
    }
    c.text =
        thousands(tc.rgb.size()) + " colours of " + spec.texture + " (" +
        (tc.rgb.size() < tc.distinct
             ? "an even subset of its " + thousands(tc.distinct) + " distinct ones, "
             : std::string("every distinct one, ")) +
        thousands(tc.pixels) + " pixels" +
        (tc.transparent ? ", " + thousands(tc.transparent) + " with alpha 0 left out"
                        : std::string()) +
        (tc.replaced ? ", " + thousands(tc.replaced) + " with NaN/Inf taken as 0" : std::string()) +
        (tc.clamped ? ", " + thousands(tc.clamped) + " clamped into [0, 1]" : std::string()) +
        "; " + tc.colorspace + ")";
    return c;
}

}  // namespace

PlanColours plan_colours(const PlanSpec& spec) {
    PlanColours c = spec.texture.empty() ? cube_sample_colours(spec) : texture_sample_colours(spec);
    c.srgb.resize(3, static_cast<Eigen::Index>(c.sr.size()));
    for (size_t i = 0; i < c.sr.size(); ++i)
        c.srgb.col(static_cast<Eigen::Index>(i)) << c.sr[i], c.sg[i], c.sb[i];
    return c;
}

}  // namespace spectex
