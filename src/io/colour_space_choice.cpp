// Choosing a file's input colour space: --colorspace, what the file states (ICC profile,
// chromaticities, metadata tags) when the config can name it, the config's file rules; the names
// offered when a name is unknown; the tags recorded for --update. Applying the chosen space (the
// OCIO processors, the code table) is io/linearizer.cpp's.
#include "io/colour_space_choice.h"

#include <OpenColorIO/OpenColorIO.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>

#include "base/error.h"
#include "base/text.h"
#include "io/icc_profile.h"
#include "io/linearizer.h"

namespace OCIO = OCIO_NAMESPACE;

namespace spectex {

// Names under which configs in the wild (ours, the ACES CG/Studio configs) call linear Rec.709.
const std::vector<std::string> kLinearRec709Names = {
    "lin_rec709_srgb",         "lin_srgb",   "Linear Rec.709 (sRGB)",
    "Utility - Linear - sRGB", "lin_rec709", "Utility - Linear - Rec.709"};

namespace {

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

// Every name and alias of a config's colour spaces, and whether each space is linear (1), encoded
// (0) or neither (-1: data, or nothing says): its OCIO encoding when the config gives one, else
// the words of its name.
std::vector<std::string> all_names(const OCIO::ConstConfigRcPtr& cfg, std::vector<int>* linear) {
    std::vector<std::string> out;
    for (int i = 0;
         i < cfg->getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL); ++i) {
        const char* n = cfg->getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL,
                                                      OCIO::COLORSPACE_ALL, i);
        auto cs = cfg->getColorSpace(n);
        int kind = name_says_linear(n);
        if (cs) {
            const std::string enc = lower_ascii(cs->getEncoding() ? cs->getEncoding() : "");
            if (cs->isData() || enc == "data")
                kind = -1;
            else if (enc == "scene-linear" || enc == "display-linear")
                kind = 1;
            else if (!enc.empty())
                kind = 0;
        }
        out.emplace_back(n);
        if (linear) linear->push_back(kind);
        for (size_t a = 0; cs && a < cs->getNumAliases(); ++a) {
            out.emplace_back(cs->getAlias(a));
            if (linear) linear->push_back(kind);
        }
    }
    return out;
}

// "unknown colour space 'X' in <config> (did you mean 'A', 'B'?)".
std::string unknown_space_message(const OCIO::ConstConfigRcPtr& cfg, const std::string& name,
                                  const std::string& path) {
    std::string msg = "unknown colour space '" + name + "' in " + path;
    std::vector<int> linear;
    const std::vector<std::string> known = all_names(cfg, &linear);
    auto close = close_colour_space_names(known, linear, name);
    if (!close.empty()) {
        msg += " (did you mean";
        for (size_t i = 0; i < close.size(); ++i) msg += (i ? ", '" : " '") + close[i] + "'";
        msg += "?)";
    }
    return msg;
}

// Lower-case letters and digits of a text ("Adobe RGB (1998)" -> "adobergb1998").
std::string squeezed(const std::string& s) {
    std::string k;
    for (char c : lower_ascii(s))
        if ((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9')) k += c;
    return k;
}

// The names a config may give the space an ICC profile describes: the description itself (a
// config may name a space after the profile), then the ACES names of the profiles textures come
// in. A profile of other primaries or another curve than these (ProPhoto, DCI-P3, Rec.2020 video)
// is named by none: the caller warns.
std::vector<std::string> names_for_icc(const std::string& description) {
    std::vector<std::string> v = {description};
    const std::string k = squeezed(description);
    auto add = [&](std::initializer_list<std::string> names) { v.insert(v.end(), names); };
    if (k.find("adobergb") != std::string::npos) {
        add({"Gamma 2.2 Encoded AdobeRGB", "g22_encoded_adobergb", "adobergb", "g22_adobergb_tx",
             "Utility - Gamma 2.2 - AdobeRGB - Texture"});
    } else if (k.find("displayp3") != std::string::npos) {
        add({"sRGB Encoded P3-D65", "srgb_encoded_p3d65", "srgb_encoded_p3d65_tx", "display_p3_tx",
             "srgb_p3d65"});
    } else if (k.find("srgb") != std::string::npos && k.find("linear") == std::string::npos &&
               k.find("scrgb") == std::string::npos) {
        v.insert(v.end(), kSrgbTextureNames.begin(), kSrgbTextureNames.end());
    } else if (k.find("srgb") != std::string::npos) {
        v.insert(v.end(), kLinearRec709Names.begin(), kLinearRec709Names.end());
    }
    return v;
}

// The primaries an OpenEXR file's chromaticities attribute may state, and the names of their
// linear space (OpenEXR's pixels are linear). Tolerance 0.0005 in x and y: the values are floats of
// figures given to 3 or 4 decimals, and the nearest two sets (Rec.709 and Adobe RGB's green) are
// 0.09 apart.
struct KnownPrimaries {
    const char* label;
    float xy[8];
    std::vector<std::string> names;
};
const std::vector<KnownPrimaries>& known_primaries() {
    static const std::vector<KnownPrimaries> k = {
        {"Rec.709",
         {0.64f, 0.33f, 0.30f, 0.60f, 0.15f, 0.06f, 0.3127f, 0.3290f},
         kLinearRec709Names},
        {"P3-D65",
         {0.680f, 0.320f, 0.265f, 0.690f, 0.150f, 0.060f, 0.3127f, 0.3290f},
         {"Linear P3-D65", "lin_p3d65"}},
        {"Rec.2020",
         {0.708f, 0.292f, 0.170f, 0.797f, 0.131f, 0.046f, 0.3127f, 0.3290f},
         {"Linear Rec.2020", "lin_rec2020"}},
        {"Adobe RGB (1998)",
         {0.64f, 0.33f, 0.21f, 0.71f, 0.15f, 0.06f, 0.3127f, 0.3290f},
         {"Linear AdobeRGB", "lin_adobergb"}},
        {"ACES AP1",
         {0.713f, 0.293f, 0.165f, 0.830f, 0.128f, 0.044f, 0.32168f, 0.33767f},
         {"ACEScg", "lin_ap1"}},
        {"ACES AP0",
         {0.7347f, 0.2653f, 0.0f, 1.0f, 0.0001f, -0.077f, 0.32168f, 0.33767f},
         {"ACES2065-1", "lin_ap0"}},
    };
    return k;
}
const KnownPrimaries* find_primaries(const std::vector<float>& c) {
    for (const auto& k : known_primaries()) {
        bool same = c.size() == 8;
        for (size_t i = 0; same && i < 8; ++i) same = std::fabs(c[i] - k.xy[i]) <= 5e-4f;
        if (same) return &k;
    }
    return nullptr;
}
std::string chromaticities_text(const std::vector<float>& c) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "R %.4g,%.4g G %.4g,%.4g B %.4g,%.4g white %.4g,%.4g", c[0],
                  c[1], c[2], c[3], c[4], c[5], c[6], c[7]);
    return buf;
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

// What the file's ICC profile says: read from its bytes, or as recorded in a header.
IccProfileInfo icc_of(const ColourTags& tags) {
    if (tags.icc_refused) return {"", "libpng refused its iCCP chunk as malformed"};
    if (tags.icc.empty()) return {tags.icc_description, tags.icc_problem};
    return read_icc_profile(tags.icc.data(), tags.icc.size());
}

}  // namespace

std::string find_first(const OCIO::ConstConfigRcPtr& cfg, const std::vector<std::string>& names) {
    for (const auto& n : names)
        if (auto c = find_space(cfg, n); !c.empty()) return c;
    return "";
}

// The input colour space of a request, first that applies: --colorspace; what the file states (its
// ICC profile, its OpenEXR chromaticities, a tag such as PNG's sRGB chunk) when the config can name
// it; a file rule of the config other than its default; what OpenImageIO assumes for the format;
// the default rule. Sets how it was chosen, the file rule, whether it is the default rule, and a
// warning when the file states a space the config cannot name. Throws Error.
std::string choose_space(const OCIO::ConstConfigRcPtr& cfg, const std::string& path,
                         const ColourRequest& req, std::string& how, std::string& rule_name,
                         bool& default_rule, std::vector<std::string>& warnings) {
    const ColourTags& tags = req.tags;
    std::string src, unnamed;  // unnamed: what the file states that the config cannot name
    if (!req.colorspace.empty()) {
        src = find_space(cfg, req.colorspace);
        if (src.empty()) throw Error(unknown_space_message(cfg, req.colorspace, path));
        how = "--colorspace";
    }
    if (src.empty() && (!tags.icc.empty() || tags.icc_refused || !tags.icc_description.empty() ||
                        !tags.icc_problem.empty())) {
        const IccProfileInfo icc = icc_of(tags);
        const std::string desc = one_line(icc.description);
        if (!icc.description.empty()) src = find_first(cfg, names_for_icc(icc.description));
        if (!src.empty())
            how = "ICC profile '" + desc + "'";
        else if (!icc.description.empty())
            unnamed = "the embedded ICC profile '" + desc + "', which the config cannot name";
        else
            unnamed = "an embedded ICC profile spectex cannot read (" + icc.problem + ")";
    }
    if (src.empty() && unnamed.empty() && !tags.chromaticities.empty()) {
        if (const KnownPrimaries* k = find_primaries(tags.chromaticities)) {
            src = find_first(cfg, k->names);
            if (!src.empty())
                how = "OpenEXR chromaticities (" + std::string(k->label) + ")";
            else
                unnamed = "the file's " + std::string(k->label) +
                          " chromaticities, which the config cannot name";
        } else {
            unnamed = "the file's chromaticities (" + chromaticities_text(tags.chromaticities) +
                      "), primaries of no colour space spectex knows";
        }
    }
    if (src.empty() && unnamed.empty() && !tags.hint_from.empty()) {
        src = find_first(cfg, names_for_hint(tags.hint));
        if (!src.empty())
            how = "file metadata: " + tags.hint_from + " (" + one_line(tags.hint) + ")";
        else
            unnamed = "the file's " + tags.hint_from + " ('" + one_line(tags.hint) +
                      "'), which the config cannot name";
    }
    if (src.empty()) {
        std::string rule_space;
        try {
            size_t rule = 0;
            rule_space = cfg->getColorSpaceFromFilepath(req.file_path.c_str(), rule);
            OCIO::ConstFileRulesRcPtr rules = cfg->getFileRules();
            rule_name = rules->getName(rule);
            // OCIO keeps the default rule last: it matches what no other rule does.
            default_rule = rule + 1 == rules->getNumEntries();
        } catch (const OCIO::Exception& e) {
            throw Error(path + ": file rules failed: " + e.what());
        }
        // OpenImageIO's assumption for the format comes after the config's own rules for the file
        // (a rule "*_nrm.png -> Raw" is not overridden by a guess), before its default rule.
        if (default_rule && tags.hint_from.empty() && !tags.hint.empty())
            if (src = find_first(cfg, names_for_hint(tags.hint)); !src.empty()) {
                how = "OpenImageIO's default for " + tags.format + " files (" +
                      one_line(tags.hint) + ")";
                rule_name.clear();
                default_rule = false;
            }
        if (src.empty()) {
            src = find_space(cfg, rule_space);
            if (src.empty())
                throw Error(path + ": the config's file rules name no known colour space");
            how = "config file rule '" + rule_name + "'";
        }
    }
    if (!unnamed.empty()) {
        how += "; not " + unnamed;
        warnings.push_back(unnamed + " (config " + path + "): read as '" + src + "' (" +
                           how.substr(0, how.find("; not ")) +
                           "); if that is wrong, bake with --colorspace NAME");
    }
    return src;
}

std::vector<std::string> close_colour_space_names(const std::vector<std::string>& known,
                                                  const std::string& name, size_t max) {
    return close_colour_space_names(known, std::vector<int>(known.size(), -1), name, max);
}

int name_says_linear(const std::string& name) {
    const std::string n = lower_ascii(name);
    auto has = [&](const char* w) { return n.find(w) != std::string::npos; };
    const bool says_lin = has("linear") || n.rfind("lin_", 0) == 0 || has(" lin") ||
                          has("acescg") || has("aces2065") || has("lin_ap") || has("scene_linear");
    const bool says_enc = has("encoded") || has("srgb") || has("gamma") || has("texture") ||
                          has("_tx") || has("log") || has("display") || has("rec1886") ||
                          has("pq") || has("hlg") || n.rfind("g18", 0) == 0 ||
                          n.rfind("g22", 0) == 0 || n.rfind("g24", 0) == 0 || has("acescc");
    if (says_lin && !has("encoded") && !has("texture") && !has("_tx")) return 1;
    if (says_enc && !says_lin) return 0;
    if (says_enc) return 0;  // "sRGB Encoded ... (linear)": the encoding wins
    return -1;
}

std::vector<std::string> close_colour_space_names(const std::vector<std::string>& known,
                                                  const std::vector<int>& linear,
                                                  const std::string& name, size_t max) {
    const int want = name_says_linear(name);
    const std::string lname = lower_ascii(name);
    struct Scored {
        bool other_kind;
        size_t distance;
        std::string name;
    };
    std::vector<Scored> scored;
    for (size_t i = 0; i < known.size(); ++i) {
        const int kind = i < linear.size() ? linear[i] : -1;
        const bool other = want >= 0 && kind != want;
        const size_t d = edit_distance(lower_ascii(known[i]), lname);
        // A name of the same kind may be further off in letters ("sRGB Encoded Rec.709 (sRGB)"
        // and "sRGB - Texture"); one of the other kind must be close.
        const size_t limit = want >= 0 && !other ? std::max<size_t>(3, 2 * name.size() / 3)
                                                 : std::max<size_t>(3, name.size() / 2);
        if (d <= limit) scored.push_back({other, d, known[i]});
    }
    std::stable_sort(scored.begin(), scored.end(), [](const Scored& a, const Scored& b) {
        return a.other_kind != b.other_kind ? !a.other_kind : a.distance < b.distance;
    });
    std::vector<std::string> out;
    for (const auto& s : scored) {
        if (out.size() >= max) break;
        out.push_back(s.name);
    }
    return out;
}

std::string colour_tags_record(const ColourTags& tags) {
    nlohmann::json j = {
        {"format", tags.format}, {"hint", tags.hint}, {"hint_from", tags.hint_from}};
    if (!tags.icc.empty() || tags.icc_refused || !tags.icc_description.empty() ||
        !tags.icc_problem.empty()) {
        const IccProfileInfo icc = icc_of(tags);
        j["icc"] = icc.description;
        j["icc_problem"] = icc.problem;
    }
    if (!tags.chromaticities.empty()) j["chromaticities"] = tags.chromaticities;
    // Invalid UTF-8 in a profile's description is replaced, never thrown on.
    return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

ColourTags colour_tags_from_record(const std::string& text) {
    ColourTags tags;
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (!j.is_object()) return tags;  // none recorded, or not ours: what the file rules choose
    auto str = [&j](const char* key) {
        auto it = j.find(key);
        return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
    };
    tags.format = str("format");
    tags.hint = str("hint");
    tags.hint_from = str("hint_from");
    tags.icc_description = str("icc");
    tags.icc_problem = str("icc_problem");
    if (j.contains("icc") && tags.icc_description.empty() && tags.icc_problem.empty())
        tags.icc_problem = "recorded without a description";
    auto it = j.find("chromaticities");
    if (it != j.end() && it->is_array() && it->size() == 8)
        for (const auto& v : *it)
            if (v.is_number()) tags.chromaticities.push_back(v.get<float>());
    if (tags.chromaticities.size() != 8) tags.chromaticities.clear();
    return tags;
}

}  // namespace spectex
