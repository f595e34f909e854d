#include "io/linearizer.h"

#include <OpenColorIO/OpenColorIO.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <mutex>
#include <sstream>
#include <utility>

#include "io/image_library.h"
#include "io/paths.h"
#include "spectral/bounded_read.h"
#include "spectral/error.h"
#include "spectral/text.h"

namespace OCIO = OCIO_NAMESPACE;

namespace spectex {

namespace {

// Names under which configs in the wild (ours, the ACES CG/Studio configs) call linear Rec.709.
const std::vector<std::string> kLinearRec709Names = {
    "lin_rec709_srgb",         "lin_srgb",   "Linear Rec.709 (sRGB)",
    "Utility - Linear - sRGB", "lin_rec709", "Utility - Linear - Rec.709"};
const std::vector<std::string> kSrgbTextureNames = {"srgb_tx", "sRGB - Texture",
                                                    "Utility - sRGB - Texture", "sRGB"};

size_t edit_distance(const std::string& a, const std::string& b) {
    std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
        cur[0] = i;
        for (size_t j = 1; j <= b.size(); ++j)
            cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1])});
        std::swap(prev, cur);
    }
    return prev[b.size()];
}

// Canonical name of a colour space (name, alias or role), or "" when the config lacks it.
std::string find_space(const OCIO::ConstConfigRcPtr& cfg, const std::string& name) {
    if (name.empty()) return "";
    OCIO::ConstColorSpaceRcPtr cs = cfg->getColorSpace(name.c_str());
    return cs ? cs->getName() : "";
}

std::string find_first(const OCIO::ConstConfigRcPtr& cfg, const std::vector<std::string>& names) {
    for (const auto& n : names)
        if (auto c = find_space(cfg, n); !c.empty()) return c;
    return "";
}

std::vector<std::string> all_names(const OCIO::ConstConfigRcPtr& cfg) {
    std::vector<std::string> out;
    for (int i = 0;
         i < cfg->getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL); ++i) {
        const char* n = cfg->getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL,
                                                      OCIO::COLORSPACE_ALL, i);
        out.emplace_back(n);
        auto cs = cfg->getColorSpace(n);
        for (size_t a = 0; cs && a < cs->getNumAliases(); ++a) out.emplace_back(cs->getAlias(a));
    }
    return out;
}

// OIIO's generic oiio:ColorSpace values, mapped to the names configs use for them.
std::vector<std::string> names_for_hint(const std::string& hint) {
    std::string h = lower_ascii(hint);
    if (h == "srgb" || h == "srgb_texture") return kSrgbTextureNames;
    if (h == "linear" || h == "scene_linear" || h == "lin_srgb") {
        std::vector<std::string> v = kLinearRec709Names;
        v.push_back("scene_linear");
        return v;
    }
    if (h == "gamma2.2") return {"g22_rec709_tx", "Gamma 2.2 Rec.709 - Texture"};
    return {hint};
}

// The folder a config's relative search paths are resolved from, as CreateFromFile sets it: the
// absolute folder of the config file.
std::string config_dir(const std::string& path) {
    std::string abs = path;
    if (abs.empty() || abs[0] != '/') {
        char cwd[PATH_MAX];
        if (::getcwd(cwd, sizeof cwd)) abs = std::string(cwd) + "/" + path;
    }
    return folder_of(abs);
}

// Every FileTransform anywhere in `t` (groups included).
void collect_file_transforms(const OCIO::ConstTransformRcPtr& t, std::vector<std::string>& out,
                             int depth = 0) {
    if (!t || depth > 64) return;
    if (auto f = OCIO::DynamicPtrCast<const OCIO::FileTransform>(t)) {
        if (f->getSrc() && *f->getSrc()) out.emplace_back(f->getSrc());
    } else if (auto g = OCIO::DynamicPtrCast<const OCIO::GroupTransform>(t)) {
        for (int i = 0; i < g->getNumTransforms(); ++i)
            collect_file_transforms(g->getTransform(i), out, depth + 1);
    }
}

// The LUT files a config references (FileTransform src in its colour spaces, looks, view and named
// transforms), resolved through the config's context as the processor would: each must be a
// regular file of bounded size, checked before OCIO reads it (a LUT on /dev/zero, /dev/urandom or
// a FIFO would otherwise hang the processor build). A reference that does not resolve is left to
// OCIO, which reports it when (and only when) a transform uses it.
// The resolved paths of the LUT files a config references (those that resolve).
std::vector<std::pair<std::string, std::string>> lut_files(const OCIO::ConstConfigRcPtr& cfg) {
    std::vector<std::string> srcs;
    const int n = cfg->getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL);
    for (int i = 0; i < n; ++i) {
        auto cs = cfg->getColorSpace(cfg->getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL,
                                                                   OCIO::COLORSPACE_ALL, i));
        if (!cs) continue;
        collect_file_transforms(cs->getTransform(OCIO::COLORSPACE_DIR_TO_REFERENCE), srcs);
        collect_file_transforms(cs->getTransform(OCIO::COLORSPACE_DIR_FROM_REFERENCE), srcs);
    }
    for (int i = 0; i < cfg->getNumLooks(); ++i) {
        auto look = cfg->getLook(cfg->getLookNameByIndex(i));
        if (!look) continue;
        collect_file_transforms(look->getTransform(), srcs);
        collect_file_transforms(look->getInverseTransform(), srcs);
    }
    for (int i = 0; i < cfg->getNumViewTransforms(); ++i) {
        auto vt = cfg->getViewTransform(cfg->getViewTransformNameByIndex(i));
        if (!vt) continue;
        collect_file_transforms(vt->getTransform(OCIO::VIEWTRANSFORM_DIR_TO_REFERENCE), srcs);
        collect_file_transforms(vt->getTransform(OCIO::VIEWTRANSFORM_DIR_FROM_REFERENCE), srcs);
    }
    for (int i = 0; i < cfg->getNumNamedTransforms(OCIO::NAMEDTRANSFORM_ALL); ++i) {
        auto nt =
            cfg->getNamedTransform(cfg->getNamedTransformNameByIndex(OCIO::NAMEDTRANSFORM_ALL, i));
        if (!nt) continue;
        collect_file_transforms(nt->getTransform(OCIO::TRANSFORM_DIR_FORWARD), srcs);
        collect_file_transforms(nt->getTransform(OCIO::TRANSFORM_DIR_INVERSE), srcs);
    }
    std::sort(srcs.begin(), srcs.end());
    srcs.erase(std::unique(srcs.begin(), srcs.end()), srcs.end());
    OCIO::ConstContextRcPtr ctx = cfg->getCurrentContext();
    std::vector<std::pair<std::string, std::string>> out;  // (src as written, resolved path)
    for (const auto& src : srcs) {
        try {
            out.emplace_back(src, ctx->resolveFileLocation(src.c_str()));
        } catch (const OCIO::Exception&) {
            // missing: OCIO's own error, if a transform in use needs it
        }
    }
    return out;
}

void check_lut_files(const OCIO::ConstConfigRcPtr& cfg, const std::string& config_path) {
    for (const auto& [src, resolved] : lut_files(cfg))
        check_regular_file(resolved, file_limits::kLutFile,
                           "a LUT file (FileTransform '" + src + "' in " + config_path + ")");
}

// An OCIO config read from checked bytes (a regular file of bounded size, never a device or a
// FIFO), with the working folder CreateFromFile would give it, and its LUT files checked too.
OCIO::ConstConfigRcPtr parse_ocio_config(const std::string& path, const std::string& bytes) {
    std::istringstream text(bytes);
    OCIO::ConstConfigRcPtr cfg;
    try {
        OCIO::ConfigRcPtr editable = OCIO::Config::CreateFromStream(text)->createEditableCopy();
        editable->setWorkingDir(config_dir(path).c_str());
        cfg = editable;
    } catch (const OCIO::Exception& e) {
        std::string why = e.what();
        for (char& c : why)
            if (c == '\n' || c == '\r') c = ' ';
        throw Error(path + ": cannot load OCIO config: " + why);
    }
    try {
        check_lut_files(cfg, path);
    } catch (const OCIO::Exception& e) {
        throw Error(path + ": cannot list the config's LUT files: " + e.what());
    }
    return cfg;
}

// A config is parsed once per process for the same path and the same bytes: a batch of many small
// files parsed the YAML again for every file (1.4 ms of a tiny file's 5.4 ms of CPU). The file is
// still read every time, so a config edited during a batch is parsed anew. OCIO's configs are
// immutable once made (Const) and safe to share between threads; reusing one also reuses its own
// cache of processors.
OCIO::ConstConfigRcPtr load_ocio_config(const std::string& path) {
    std::string bytes = read_file_bounded(path, file_limits::kOcioConfig, "an OCIO config");
    static std::mutex mutex;
    static std::map<std::pair<std::string, std::string>, OCIO::ConstConfigRcPtr> parsed;
    std::lock_guard<std::mutex> lock(mutex);
    auto key = std::make_pair(path, std::move(bytes));
    const auto it = parsed.find(key);
    if (it != parsed.end()) return it->second;
    OCIO::ConstConfigRcPtr cfg = parse_ocio_config(path, key.second);
    if (parsed.size() >= 8)
        parsed.clear();  // a batch uses one or two configs; never grow without bound
    parsed.emplace(std::move(key), cfg);
    return cfg;
}

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

// The input colour space of a request: 1. --colorspace, 2. the file's own metadata when the config
// knows it, 3. the file rules. Sets how it was chosen, the file rule and whether it is the default
// rule. Throws Error.
std::string choose_space(const OCIO::ConstConfigRcPtr& cfg, const std::string& path,
                         const ColourRequest& req, std::string& how, std::string& rule_name,
                         bool& default_rule) {
    std::string src;
    if (!req.colorspace.empty()) {
        src = find_space(cfg, req.colorspace);
        if (src.empty()) {
            std::string msg = "unknown colour space '" + req.colorspace + "' in " + path;
            auto close = close_colour_space_names(all_names(cfg), req.colorspace);
            if (!close.empty()) {
                msg += " (did you mean";
                for (size_t i = 0; i < close.size(); ++i)
                    msg += (i ? ", '" : " '") + close[i] + "'";
                msg += "?)";
            }
            throw Error(msg);
        }
        how = "--colorspace";
    }
    if (src.empty() && !req.file_hint.empty()) {
        src = find_first(cfg, names_for_hint(req.file_hint));
        if (!src.empty()) how = "file metadata (" + req.file_hint + ")";
    }
    if (src.empty()) {
        try {
            size_t rule = 0;
            src = cfg->getColorSpaceFromFilepath(req.file_path.c_str(), rule);
            OCIO::ConstFileRulesRcPtr rules = cfg->getFileRules();
            rule_name = rules->getName(rule);
            // OCIO keeps the default rule last: it matches what no other rule does.
            default_rule = rule + 1 == rules->getNumEntries();
        } catch (const OCIO::Exception& e) {
            throw Error(path + ": file rules failed: " + e.what());
        }
        src = find_space(cfg, src);
        if (src.empty()) throw Error(path + ": the config's file rules name no known colour space");
        how = "config file rule '" + rule_name + "'";
    }
    return src;
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

std::vector<std::string> close_colour_space_names(const std::vector<std::string>& known,
                                                  const std::string& name, size_t max) {
    std::vector<std::pair<size_t, std::string>> scored;
    for (const auto& k : known)
        scored.emplace_back(edit_distance(lower_ascii(k), lower_ascii(name)), k);
    std::stable_sort(scored.begin(), scored.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<std::string> out;
    for (const auto& s : scored) {
        if (out.size() >= max) break;
        if (s.first <= std::max<size_t>(3, name.size() / 2)) out.push_back(s.second);
    }
    return out;
}

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
    const std::string src = choose_space(cfg, path, req, lin.how_, lin.rule_, lin.default_rule_);
    lin.input_space_ = src;

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
    ColourTransform t;
    t.space = choose_space(cfg, path, req, how, rule, default_rule);
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

std::vector<std::string> ocio_config_files(const std::string& config_path) {
    std::vector<std::string> files = {config_path};
    OCIO::ConstConfigRcPtr cfg = load_ocio_config(config_path);
    for (const auto& f : lut_files(cfg)) files.push_back(f.second);
    return files;
}

std::string srgb_texture_space(const std::string& data_dir, const std::string& config_override) {
    const std::string path = ocio_config_path(data_dir, config_override),
                      shipped = data_dir + "/spectex.ocio";
    OCIO::ConstConfigRcPtr cfg = load_ocio_config(path);
    // Codes and the linear values the IEC 61966-2-1 curve gives them, one colour per channel mix
    // (so that a space with other primaries, which mixes channels, does not pass).
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
                    same = same && std::fabs(px[4 * p + c] - eotf(codes[p][c])) <= 1e-4;
            if (same) return name;
        } catch (const std::exception&) {
            // a space this config cannot convert: not the one
        }
    }
    return "";
}

std::string ocio_config_path(const std::string& data_dir, const std::string& config_override) {
    if (!config_override.empty()) return config_override;
    if (const char* env = std::getenv("OCIO"); env && *env) return env;
    return data_dir + "/spectex.ocio";
}

}  // namespace spectex
