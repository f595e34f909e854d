#include "pipeline/update_check.h"

#include <sys/stat.h>

#include <map>

#include "base/bounded_read.h"
#include "base/fnv1a.h"
#include "io/exr_preflight.h"
#include "io/linearizer.h"
#include "io/ocio_config.h"
#include "io/provenance_keys.h"
#include "io/source_identity.h"
#include "io/spectral_exr_info.h"
#include "spectex/version.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

void fnv(Fnv1a64& h, const std::string& s) {
    h.add(s.data(), s.size());
    const unsigned char separator = 0xff;  // "ab"+"c" differs from "a"+"bc"
    h.add(&separator, 1);
}

// The colour config's bytes, for the settings hash: a regular file of bounded size (never
// /dev/zero or a FIFO, which would never end), checked like every file spectex reads.
std::string file_contents(const std::string& path) {
    return read_file_bounded(path, file_limits::kOcioConfig, "an OCIO config");
}

// The settings both hashes share (everything but the colour config).
void hash_settings(Fnv1a64& h, const BakeSettings& s) {
    fnv(h, SPECTEX_VERSION);
    fnv(h, !s.method_recipe.empty() ? s.method_recipe : s.method->checksum());
    for (double l : s.grid.lambda)
        fnv(h, format_wavelength(l));  // none yet with --wavelengths auto
    fnv(h, s.type == SampleType::Half ? "half" : "float");
    fnv(h, s.compression.name);
    if (s.zip_level == 0)
        fnv(h, "zip-level by size");  // the default bake's (DefaultBake::zip_level)
    else if (s.zip_level != 4)
        fnv(h, "zip-level " + std::to_string(s.zip_level));  // 4: hashes as before
    fnv(h, s.preview ? "preview" : "");
    fnv(h, to_string(s.alpha));
    fnv(h, to_string(s.range));
    fnv(h, to_string(s.nan));
    fnv(h, s.observer);
    fnv(h, s.illuminant);
    fnv(h, s.colorspace);
    fnv(h, s.colour_rounding ? "colour-rounding" : "nearest");
    fnv(h, std::to_string(s.tile_width) + "x" + std::to_string(s.tile_height) +
               (s.mipmap ? "mip" : ""));
    // Straight MIP levels are filtered weighted by alpha: files whose levels let hidden colours
    // bleed in (made before) are other pixels, so --update rebakes them; every other hash stays.
    if (s.mipmap && s.alpha == AlphaKind::Unassociated) fnv(h, "straight levels weighted by alpha");
    // The wrapmodes recorded, when they differ from what the output records without --wrap
    // (black,black in a tiled file, nothing in a scanline one): those hashes stay as they were.
    const std::string no_wrap = s.tile_width > 0 || s.mipmap ? "black,black" : "";
    if (!s.wrapmodes.empty() && s.wrapmodes != no_wrap) fnv(h, "wrapmodes " + s.wrapmodes);
    // --wavelengths auto: the choice's settings (the chosen grid is hashed above); nothing when the
    // grid was given, so those hashes stay as they were.
    if (!s.plan.lights.empty())
        fnv(h, "plan " + s.plan.lights + "|" + s.plan.max_de + "|" + s.plan.reconstruction + "|" +
                   s.plan.range + (s.plan.nonuniform ? "|nonuniform" : ""));
    // --precision auto: what chooses the bits (nothing for full half: those hashes stay as they
    // were).
    if (!s.precision.recipe.empty()) fnv(h, "precision " + s.precision.recipe);
}

}  // namespace

std::string settings_hash(const BakeSettings& s) {
    Fnv1a64 h;
    hash_settings(h, s);
    // The colour config is judged per file by what it does (spectex:colorTransform), not here.
    fnv(h, "colour by transform");
    return h.text();
}

std::string legacy_settings_hash(const BakeSettings& s) {
    Fnv1a64 h;
    hash_settings(h, s);
    // The colour config's path and bytes, as spectex hashed them before it recorded the transform.
    const std::string config = ocio_config_path(s.data_dir, s.config);
    fnv(h, config);
    fnv(h, file_contents(config));
    return h.text();
}

UpdateCheck check_update(const std::string& input, const std::string& output,
                         const BakeSettings& s) {
    UpdateCheck c;
    struct stat si;
    if (::stat(input.c_str(), &si) != 0 || !S_ISREG(si.st_mode)) {
        c.reason = "the input cannot be examined";  // the bake reports why
        return c;
    }
    std::map<std::string, std::string> h;
    try {
        exr_preflight(output, &h);  // the header's bytes only: never the pixels
    } catch (const std::exception&) {
        c.reason = "no readable output";
        return c;
    }
    auto value = [&](const char* name) {
        auto it = h.find(name);
        return it == h.end() ? std::string() : it->second;
    };
    // An output that records its colour transform has a settings hash without the config, and the
    // transform is compared below; one made before has the config's bytes in its hash (judged as
    // then: rebaked once when the config's bytes changed, and then it records the transform).
    const std::string recorded_transform = value(provenance_key::kColorTransform);
    const bool by_transform = !recorded_transform.empty();
    if (value(provenance_key::kSettingsHash) !=
        (by_transform ? s.settings_hash : s.legacy_settings_hash)) {
        c.reason = by_transform ? "other settings"
                                : "other settings or OCIO config (the output records no colour "
                                  "transform: it was baked by an older spectex)";
        return c;
    }
    if (by_transform) {
        // The space this file would be read as now, from the same request as the bake's (the
        // metadata it recorded), and what the config does to it.
        try {
            const ColourTransform now = colour_transform(ColourRequest{
                s.data_dir, s.config, s.colorspace, input,
                colour_tags_from_record(value(provenance_key::kInputColorSpaceMetadata))});
            if (now.space != value(provenance_key::kInputColorSpace)) {
                c.reason = "the OCIO config now reads the source as '" + now.space + "', not '" +
                           value(provenance_key::kInputColorSpace) + "'";
                return c;
            }
            if (now.id != recorded_transform) {
                c.reason = "the OCIO config's transform from '" + now.space +
                           "' to linear Rec.709 changed";
                return c;
            }
        } catch (const std::exception& e) {
            c.reason = std::string("the colour transform cannot be made: ") + e.what();
            return c;
        }
    }
    const std::string size = value(provenance_key::kSourceSize);
    const std::string mtime = value(provenance_key::kSourceMtime);
    const std::string recorded = value(provenance_key::kSourceHash);
    if (size.empty() || mtime.empty() || recorded.empty()) {
        c.reason = "the output does not record its source's identity";
        return c;
    }
    const SourceIdentity now = SourceIdentity::of(si);
    if (now.size_text() != size) {
        c.reason = "the source's size changed";
        return c;
    }
    // Up to date but for the pixels: a copy cut short keeps its header (and the bake's records),
    // so the chunk tables are read too (not the pixels).
    auto whole = [&] {
        if (exr_chunks_within_file(output)) return true;
        c.reason =
            "the output is incomplete: chunks of the pixel data are missing (a truncated "
            "or interrupted file)";
        return false;
    };
    if (now.mtime_text() == mtime) {
        if (!whole()) return c;
        c.up_to_date = true;
        c.reason = "up to date: same settings hash, source size and modification time";
        return c;
    }
    // Same size, another time: a touch, a checkout or a restore of the same bytes keeps the output;
    // a replacement of the same size does not. The bytes are read, not decoded.
    try {
        if (hash_file(input) == recorded) {
            if (!whole()) return c;
            c.up_to_date = true;
            c.reason =
                "up to date: same settings hash and source bytes (its modification time changed)";
            return c;
        }
    } catch (const std::exception&) {
    }
    c.reason = "the source's contents changed";
    return c;
}

}  // namespace spectex
