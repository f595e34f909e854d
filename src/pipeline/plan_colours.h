#pragma once
// What a plan measures on: the scene (the renderer's range at 1 nm, the observer, each light's
// weights) and the colours that decide (a dense sample of the 8-bit cube, or a texture's own).
#include <Eigen/Dense>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/plan.h"
#include "spectral/grid_error.h"
#include "spectral/spectrum.h"

namespace spectex {

// The scene as the renderer sees it: its range at 1 nm, the observer, and each light's weights.
struct PlanScene {
    WavelengthGrid fine;
    Observer observer;
    std::vector<LightWeights> lights;
};

// Reads the observer and each light of spec on the renderer's range. Throws Error.
PlanScene load_plan_scene(const PlanSpec& spec);

// The colours that decide: the dense sample of the 8-bit cube, or the texture's own (every row on
// them), in linear sRGB with the 8-bit sRGB code of each (for the worst colour).
struct PlanColours {
    std::vector<std::array<uint8_t, 3>> codes;
    std::vector<float> sr, sg, sb;
    Eigen::Matrix3Xd srgb;
    std::string text;  // how they were taken, for the report
};

// spec.texture's colours (read as bake reads it) when it names one, else the cube sample of
// spec.sample_stride; srgb filled from sr, sg, sb. Throws Error naming the texture.
PlanColours plan_colours(const PlanSpec& spec);

}  // namespace spectex
