#include "io/linearizer.h"

#include <OpenColorIO/OpenColorIO.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <utility>

#include "base/bounded_read.h"
#include "base/error.h"
#include "base/fnv1a.h"
#include "base/memo.h"
#include "base/text.h"
#include "io/colour_space_choice.h"
#include "io/image_library.h"
#include "io/ocio_config.h"
#include "io/paths.h"

namespace OCIO = OCIO_NAMESPACE;

namespace spectex {

namespace {

// The processor from `src` of `cfg` to linear Rec.709: inside the config when it has that space,
// else bridged to ours through ACES2065-1 (the aces_interchange role). Throws OCIO::Exception.
OCIO::ConstProcessorRcPtr processor_to_linear(const OCIO::ConstConfigRcPtr& cfg,
                                              const std::string& src, const std::string& path,
                                              const std::string& shipped) {
    const std::string dst = find_first(cfg, kLinearRec709Names);
    if (!dst.empty()) return cfg->getProcessor(src.c_str(), dst.c_str());
    if (!cfg->hasRole("aces_interchange"))
        throw Error(path +
                    ": config has no linear Rec.709 space (lin_srgb) and no aces_interchange role");
    return OCIO::Config::GetProcessorFromConfigs(cfg, src.c_str(), load_ocio_config(shipped),
                                                 "lin_srgb");
}

// Whether a processor is linear on RGB: f(0) = 0, f(x + y) = f(x) + f(y) and f(x / 2) = f(x) / 2 on
// a few colours, to float precision (a matrix passes to 1e-7; a transfer curve misses by 1e-2).
bool measured_linear(const OCIO::ConstCPUProcessorRcPtr& cpu) {
    const float x[3] = {0.2f, 0.5f, 0.8f}, y[3] = {0.6f, 0.1f, 0.3f};
    float px[4 * 5] = {};
    for (int c = 0; c < 3; ++c) {
        px[4 * 1 + c] = x[c];
        px[4 * 2 + c] = y[c];
        px[4 * 3 + c] = x[c] + y[c];
        px[4 * 4 + c] = x[c] / 2;
    }
    for (int p = 0; p < 5; ++p) px[4 * p + 3] = 1.0f;
    OCIO::PackedImageDesc desc(px, 5, 1, 4);
    cpu->apply(desc);
    auto near = [](float a, float b) {
        return std::isfinite(a) && std::isfinite(b) &&
               std::fabs(a - b) <= 1e-5f * (1 + std::fabs(b));
    };
    for (int c = 0; c < 3; ++c) {
        const float f0 = px[c], fx = px[4 + c], fy = px[8 + c], fxy = px[12 + c], fh = px[16 + c];
        if (!near(f0, 0) || !near(fxy, fx + fy) || !near(fh, fx / 2)) return false;
    }
    return true;
}

// "name: description" of a config, on one line.
std::string describe_config(const OCIO::ConstConfigRcPtr& cfg) {
    auto tidy = [](std::string t) {
        for (char& c : t)
            if (c == '\n' || c == '\r' || c == '\t') c = ' ';
        const size_t b = t.find_first_not_of(' '), e = t.find_last_not_of(' ');
        return b == std::string::npos ? std::string() : t.substr(b, e - b + 1);
    };
    const std::string name = tidy(cfg->getName() ? cfg->getName() : "");
    const std::string desc = tidy(cfg->getDescription() ? cfg->getDescription() : "");
    return name.empty() ? desc : desc.empty() ? name : name + ": " + desc;
}

}  // namespace

struct Linearizer::Impl {
    OCIO::ConstCPUProcessorRcPtr cpu;
    OCIO::ConstCPUProcessorRcPtr inverse;  // null when the transform cannot be inverted
    bool crosstalk = true;
    // Code table: key[i] is the float OpenImageIO gives for code i, out[c][i] OCIO's result.
    float scale = 0;
    std::vector<float> key;
    std::vector<float> out[3];
};

Linearizer::Linearizer() = default;
Linearizer::~Linearizer() = default;
Linearizer::Linearizer(Linearizer&&) noexcept = default;
Linearizer& Linearizer::operator=(Linearizer&&) noexcept = default;

Linearizer Linearizer::make(const ColourRequest& req) {
    Linearizer lin;
    lin.impl_ = std::make_unique<Impl>();
    const std::string shipped = req.data_dir + "/spectex.ocio";
    std::string path = req.config_override;
    if (path.empty())
        if (const char* env = std::getenv("OCIO"); env && *env) path = env;
    lin.config_from_ = !req.config_override.empty() ? "--config"
                       : !path.empty()              ? "$OCIO"
                                                    : "shipped";
    if (path.empty()) path = shipped;
    lin.config_path_ = path;

    OCIO::ConstConfigRcPtr cfg = load_ocio_config(path);
    lin.config_name_ = describe_config(cfg);

    lin.input_space_ =
        choose_space(cfg, path, req, lin.how_, lin.rule_, lin.default_rule_, lin.warnings_);
    const std::string& src = lin.input_space_;

    try {
        // A foreign config without linear Rec.709 is bridged to ours through ACES2065-1.
        const std::string dst = find_first(cfg, kLinearRec709Names);
        OCIO::ConstProcessorRcPtr proc = processor_to_linear(cfg, src, path, shipped);
        lin.transform_id_ = proc->getCacheID();
        lin.identity_ = proc->isNoOp();
        lin.impl_->crosstalk = proc->hasChannelCrosstalk();
        // Full-precision ops only: no LUT approximations of the transfer curves.
        lin.impl_->cpu = proc->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F32, OCIO::BIT_DEPTH_F32,
                                                        OCIO::OPTIMIZATION_LOSSLESS);
        OCIO::ConstColorSpaceRcPtr cs = cfg->getColorSpace(src.c_str());
        lin.scene_linear_ = cs && !cs->isData() &&
                            cs->getReferenceSpaceType() == OCIO::REFERENCE_SPACE_SCENE &&
                            measured_linear(lin.impl_->cpu);
        try {
            OCIO::ConstProcessorRcPtr inv =
                !dst.empty() ? cfg->getProcessor(dst.c_str(), src.c_str())
                             : OCIO::Config::GetProcessorFromConfigs(load_ocio_config(shipped),
                                                                     "lin_srgb", cfg, src.c_str());
            lin.impl_->inverse = inv->getOptimizedCPUProcessor(
                OCIO::BIT_DEPTH_F32, OCIO::BIT_DEPTH_F32, OCIO::OPTIMIZATION_LOSSLESS);
        } catch (const OCIO::Exception&) {
            lin.impl_->inverse
                .reset();  // e.g. a LUT OCIO cannot invert: no code check, the rest works
        }
    } catch (const OCIO::Exception& e) {
        throw Error(path + ": cannot build the transform from '" + src +
                    "' to linear Rec.709: " + e.what());
    }
    return lin;
}

ColourTransform colour_transform(const ColourRequest& req) {
    const std::string path = ocio_config_path(req.data_dir, req.config_override);
    OCIO::ConstConfigRcPtr cfg = load_ocio_config(path);
    std::string how, rule;
    bool default_rule = false;
    std::vector<std::string> warnings;
    ColourTransform t;
    t.space = choose_space(cfg, path, req, how, rule, default_rule, warnings);
    try {
        t.id =
            processor_to_linear(cfg, t.space, path, req.data_dir + "/spectex.ocio")->getCacheID();
    } catch (const OCIO::Exception& e) {
        throw Error(path + ": cannot build the transform from '" + t.space +
                    "' to linear Rec.709: " + e.what());
    }
    return t;
}

bool Linearizer::use_code_table(int bits) {
    Impl& I = *impl_;
    if (identity_ || I.crosstalk || bits < 1 || bits > 16) return false;
    const size_t n = size_t{1} << bits;
    // Exactly the floats OpenImageIO hands us for these codes (its conversion, not ours).
    I.key = image_library().integer_code_floats(bits <= 8 ? 8 : 16);
    I.key.resize(n);
    std::vector<float> ramp(4 * n);
    for (size_t i = 0; i < n; ++i)
        ramp[4 * i] = ramp[4 * i + 1] = ramp[4 * i + 2] = I.key[i], ramp[4 * i + 3] = 1.0f;
    OCIO::PackedImageDesc desc(ramp.data(), static_cast<long>(n), 1, 4);
    I.cpu->apply(desc);
    for (int c = 0; c < 3; ++c) {
        I.out[c].resize(n);
        for (size_t i = 0; i < n; ++i) I.out[c][i] = ramp[4 * i + static_cast<size_t>(c)];
    }
    I.scale = static_cast<float>(n - 1);
    return true;
}

std::vector<float> Linearizer::code_values() const {
    std::vector<float> v;
    if (!impl_ || impl_->key.empty()) return v;
    const size_t n = impl_->key.size();
    v.resize(3 * n);
    for (size_t i = 0; i < n; ++i)
        for (size_t c = 0; c < 3; ++c) v[3 * i + c] = impl_->out[c][i];
    return v;
}

std::vector<float> srgb_code_values(const std::string& data_dir,
                                    const std::string& config_override) {
    ColourTags tags;
    tags.hint = "sRGB";
    tags.hint_from = "8-bit sRGB codes";
    try {
        Linearizer lin = Linearizer::make(ColourRequest{data_dir, config_override, "", "", tags});
        // A config that cannot name sRGB falls back to its file rules, with a warning: not sRGB.
        if (!lin.warnings().empty() || lin.is_identity() || !lin.use_code_table(8)) return {};
        return lin.code_values();
    } catch (const Error&) {
        return {};  // the bake itself says what is wrong with the config
    }
}

bool Linearizer::can_encode() const { return identity_ || (impl_ && impl_->inverse); }

void Linearizer::encode_rgba(float* rgba, long pixels) const {
    if (identity_ || pixels <= 0) return;
    if (!impl_->inverse)
        throw Error(config_path_ + ": the transform to linear Rec.709 cannot be inverted");
    OCIO::PackedImageDesc desc(rgba, pixels, 1, 4);
    impl_->inverse->apply(desc);
}

void Linearizer::apply_rgba(float* rgba, long pixels) const {
    if (identity_ || pixels <= 0) return;
    const Impl& I = *impl_;
    if (I.key.empty()) {
        OCIO::PackedImageDesc desc(rgba, pixels, 1, 4);
        I.cpu->apply(desc);
        return;
    }
    const long last = static_cast<long>(I.key.size()) - 1;
    for (long p = 0; p < pixels; ++p) {
        float* px = rgba + 4 * p;
        bool miss = false;
        float v[3];
        for (int c = 0; c < 3; ++c) {
            const float x = px[c];
            const long i = std::lrint(x * I.scale);
            if (i >= 0 && i <= last && I.key[static_cast<size_t>(i)] == x)
                v[c] = I.out[c][static_cast<size_t>(i)];
            else
                miss = true;
        }
        if (miss) {
            OCIO::PackedImageDesc one(px, 1, 1, 4);
            I.cpu->apply(one);
        } else {
            px[0] = v[0];
            px[1] = v[1];
            px[2] = v[2];
        }
    }
}

}  // namespace spectex

namespace spectex {

std::string srgb_texture_space(const std::string& data_dir, const std::string& config_override) {
    const std::string path = ocio_config_path(data_dir, config_override),
                      shipped = data_dir + "/spectex.ocio";
    OCIO::ConstConfigRcPtr cfg = load_ocio_config(path);
    // Codes and the linear values the IEC 61966-2-1 curve gives them, one colour per channel mix
    // (so that a space with other primaries, which mixes channels, does not pass). The rounded
    // matrices of published configs decode them up to 1.3e-4 off (tests/ocio/, bridged through
    // ours): within kConfigArithmeticTolerance, which tells them from another space.
    auto eotf = [](double v) {
        return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
    };
    const float codes[3][3] = {{0.5f, 0.2f, 0.8f}, {0.04f, 0.9f, 0.3f}, {1.0f, 0.0f, 0.6f}};
    const int n =
        cfg->getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_SCENE, OCIO::COLORSPACE_ACTIVE);
    for (int i = 0; i < n; ++i) {
        const char* name = cfg->getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_SCENE,
                                                         OCIO::COLORSPACE_ACTIVE, i);
        OCIO::ConstColorSpaceRcPtr cs = cfg->getColorSpace(name);
        if (!cs || cs->isData()) continue;
        try {
            auto cpu = processor_to_linear(cfg, name, path, shipped)
                           ->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F32, OCIO::BIT_DEPTH_F32,
                                                      OCIO::OPTIMIZATION_LOSSLESS);
            float px[12];
            for (int p = 0; p < 3; ++p) {
                for (int c = 0; c < 3; ++c) px[4 * p + c] = codes[p][c];
                px[4 * p + 3] = 1.0f;
            }
            OCIO::PackedImageDesc desc(px, 3, 1, 4);
            cpu->apply(desc);
            bool same = true;
            for (int p = 0; p < 3; ++p)
                for (int c = 0; c < 3; ++c)
                    same = same && std::fabs(px[4 * p + c] - eotf(codes[p][c])) <=
                                       kConfigArithmeticTolerance;
            if (same) return name;
        } catch (const std::exception&) {
            // a space this config cannot convert: not the one
        }
    }
    return "";
}

}  // namespace spectex
