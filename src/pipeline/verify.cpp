#include "pipeline/verify.h"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <set>

#include "base/bounded_read.h"
#include "base/error.h"
#include "base/task_pool.h"
#include "base/text.h"
#include "io/exr_compression.h"
#include "io/file_identity.h"
#include "io/image_source.h"
#include "io/linearizer.h"
#include "io/ocio_config.h"
#include "io/provenance_keys.h"
#include "io/source_identity.h"
#include "io/spectral_exr_info.h"
#include "io/spectral_reader.h"
#include "pipeline/batch_files.h"
#include "pipeline/method_table.h"
#include "pipeline/pixel_policy.h"
#include "pipeline/table_memo.h"
#include "pipeline/verify_measure.h"
#include "spectral/adaptation.h"
#include "spectral/colorimetry.h"
#include "spectral/precision.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

// The file's size, bins and storage, as the report states them.
VerifyReport describe_file(const std::string& exr_path, const SpectralExrInfo& info) {
    VerifyReport r;
    r.file = exr_path;
    r.width = info.width;
    r.height = info.height;
    r.pixels = static_cast<uint64_t>(info.width) * static_cast<uint64_t>(info.height);
    r.bins = static_cast<int>(info.reflective.size());
    r.lambda_min = info.reflective.front().lambda;
    r.lambda_max = info.reflective.back().lambda;
    r.sample_type = info.sample_type;
    r.compression = info.compression;
    r.storage = info.tiled ? "tiled " + std::to_string(info.tile_width) + "x" +
                                 std::to_string(info.tile_height)
                           : std::string("scanline");
    r.samples = r.pixels * static_cast<uint64_t>(r.bins);
    return r;
}

// What the file records, and what is used: a setting given overrides the file's, with a warning.
class Recorded {
  public:
    Recorded(const SpectralExrInfo& info, std::vector<std::string>& warnings)
        : info_(info), warnings_(warnings) {}
    // A recorded setting: a name, a path or a number, never longer than a path can be. A longer
    // value is damage or a forgery (a 100,000-character illuminant was printed whole in an
    // error): it is ignored, with one warning naming the key.
    std::string operator()(const std::string& key) const {
        for (const auto& [k, v] : info_.attributes) {
            if (k != key) continue;
            if (v.size() <= kMaxRecordedSetting) return v;
            if (warned_.insert(key).second)
                warnings_.push_back(key + " is " + std::to_string(v.size()) +
                                    " characters long, not a value spectex writes: ignored");
            return std::string();
        }
        return std::string();
    }
    std::string choose(const std::string& given, const std::string& key,
                       const std::string& fallback, const std::string& option) const {
        const std::string rec = (*this)(key);
        if (given.empty()) return rec.empty() ? fallback : rec;
        if (!rec.empty() && lower_ascii(given) != lower_ascii(rec))
            warnings_.push_back(option + " '" + printable_excerpt(given, 200) +
                                "' overrides the file's '" + printable_excerpt(rec, 200) + "' (" +
                                key + ")");
        return given;
    }

  private:
    static constexpr size_t kMaxRecordedSetting = 4096;  // PATH_MAX
    const SpectralExrInfo& info_;
    std::vector<std::string>& warnings_;
    mutable std::set<std::string> warned_;
};

// The bake's settings the file records, or those given instead.
void read_recorded_settings(const Recorded& recorded, const VerifySettings& s, VerifyReport& r) {
    r.method = recorded(provenance_key::kMethod);
    // spectex before 0.1's methods recorded only the basis.
    if (r.method.empty() && !recorded(provenance_key::kBasis).empty()) r.method = "basis";
    if (const std::string v = recorded(provenance_key::kOutOfRange); !v.empty()) r.out_of_range = v;
    if (const std::string v = recorded(provenance_key::kNan); !v.empty()) r.nan = v;
    r.half_rounding = recorded(provenance_key::kHalfRounding);
    r.precision = recorded(provenance_key::kPrecision);
    if (!r.precision.empty()) {
        r.precision_max_de = recorded(provenance_key::kPrecisionMaxDe);
        r.precision_lights = recorded(provenance_key::kPrecisionLights);
        r.precision_worst_de = recorded(provenance_key::kPrecisionWorstDe);
        r.precision_covers = recorded(provenance_key::kPrecisionSample);
        try {
            r.precision_bits = parse_precision_bits(recorded(provenance_key::kPrecisionBits),
                                                    static_cast<size_t>(r.bins));
        } catch (const Error& e) {
            r.warnings.push_back(std::string(provenance_key::kPrecisionBits) + ": " + e.what());
        }
    }
    r.lossy_compression = recorded(provenance_key::kLossyCompression);
    if (r.lossy_compression.empty())
        if (const ExrCompression* c = ExrCompression::find(r.compression)) {
            const bool half = r.sample_type == "half" || r.sample_type == "mixed";
            if (c->lossy_for(half) || (r.sample_type == "mixed" && c->lossy_for(false)))
                r.lossy_compression = c->name + " (" + c->lossy_text() + ")";
        }
    r.illuminant =
        recorded.choose(s.illuminant, provenance_key::kIlluminant, "D65", "--check-illuminant");
    r.observer = recorded.choose(s.observer, provenance_key::kObserver, "cie1931-2", "--observer");
}

// The check light's colorimetry on the file's own bins; the other lights, adapted to its white,
// go to ctx.
Colorimetry file_colorimetry(const std::string& exr_path, const SpectralExrInfo& info,
                             const VerifySettings& s, VerifyReport& r, MeasureContext& ctx) {
    std::vector<double> lambdas;
    for (const auto& b : info.reflective) lambdas.push_back(b.lambda);
    try {
        WavelengthGrid grid = WavelengthGrid::from_list(lambdas);
        r.wavelengths = grid.describe();
        const auto obs = observer_table(s.data_dir, r.observer);
        Colorimetry col = Colorimetry::make(*obs, *illuminant_table(s.data_dir, r.illuminant), grid,
                                            primaries_by_name("srgb"));
        for (const auto& name : s.other_lights) {
            const Colorimetry cl = Colorimetry::make(*obs, *illuminant_table(s.data_dir, name),
                                                     grid, primaries_by_name("srgb"));
            ctx.lights.push_back({bradford_adaptation(cl.white_xyz, col.white_xyz) * cl.W});
            OtherLightReport lr;
            lr.light = name;
            r.other_lights.push_back(lr);
        }
        return col;
    } catch (const Error& e) {
        throw Error(exr_path + ": " + e.what());
    }
}

// The OCIO config for the source: the one given, else the one the bake used when it is still
// there; a missing config is warned about, and a changed one when the file records no colour
// transform (open_source compares the transform itself when it does).
std::string choose_config(const Recorded& recorded, const VerifySettings& s, VerifyReport& r) {
    std::string config = s.config;
    const std::string rec_config = recorded(provenance_key::kConfig),
                      rec_sum = recorded(provenance_key::kColorTransform).empty()
                                    ? recorded(provenance_key::kConfigChecksum)
                                    : std::string();
    if (config.empty() && !rec_config.empty()) {
        if (file_id(rec_config)) {
            config = rec_config;
            if (!rec_sum.empty() && config_checksum(rec_config) != rec_sum)
                r.warnings.push_back("the OCIO config the file records (" + rec_config +
                                     ") has changed since the bake");
        } else {
            const char* env = std::getenv("OCIO");
            r.warnings.push_back(
                "the OCIO config the file records (" + rec_config + ") is not there; using " +
                (env && *env ? "$OCIO's " : "the shipped config ") +
                ocio_config_path(s.data_dir, "") + " instead (--config FILE chooses another)");
        }
    } else if (!config.empty() && !rec_sum.empty() && config_checksum(config) != rec_sum) {
        r.warnings.push_back("--config " + config + " differs from the config the file records (" +
                             rec_config + ")");
    }
    return config;
}

// Whether `source` names the file the header records as its source (found as recorded_source finds
// it): the same file, links followed.
bool is_recorded_source(const std::string& exr, const SpectralExrInfo& info,
                        const std::string& source) {
    try {
        std::error_code ec;
        return std::filesystem::equivalent(recorded_source(exr, info.attributes), source, ec);
    } catch (const Error&) {
        return false;  // the header records no source, or it is not found
    }
}

// Whether `source` is the file the header records: its size first (a stat), then its bytes' hash
// (read, not decoded). Sets r.source_changed and r.change when it is not; nothing when the header
// records no identity. Throws Error naming the source when it cannot be read.
void check_source_identity(const std::string& source, const Recorded& recorded, VerifyReport& r) {
    VerifyReport::SourceChange c;
    c.file = source;
    c.recorded_size = recorded(provenance_key::kSourceSize);
    c.recorded_hash = recorded(provenance_key::kSourceHash);
    if (c.recorded_size.empty() && c.recorded_hash.empty()) return;
    struct stat st;
    if (::stat(source.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return;  // open_source says why
    c.size = SourceIdentity::of(st).size_text();
    if (!c.recorded_size.empty() && c.size != c.recorded_size) {
        c.why = "it has " + c.size + " bytes; it had " + c.recorded_size + " when this was baked";
    } else if (!c.recorded_hash.empty()) {
        c.hash = hash_file(source);
        if (c.hash == c.recorded_hash) return;
        c.why = "same size, other bytes: " + c.hash + ", not the " + c.recorded_hash +
                " this was baked from";
    } else {
        return;
    }
    r.source_changed = true;
    r.change = c;
}

// Per bin, how far above 1 a straight sample T/A of an associated file may be from rounding
// alone: T's relative step (2^-bits of the bin's mantissa: the precision budget's bits, 10 for
// half, 23 for float; the colour-aware rounding moves a value by at most one step) plus half's
// relative rounding of A (2^-11; a float A is exact enough) and 1e-6.
std::vector<float> straight_tolerances(const VerifyReport& r) {
    const bool half = r.sample_type == "half" || r.sample_type == "mixed";
    std::vector<float> tol(static_cast<size_t>(r.bins));
    for (size_t k = 0; k < tol.size(); ++k) {
        const int bits = !half ? 23 : k < r.precision_bits.size() ? r.precision_bits[k] : 10;
        tol[k] = static_cast<float>(1e-6 + std::ldexp(1.0, -bits) + std::ldexp(1.0, -11));
    }
    return tol;
}

// The code check, when the source's codes can be checked: what the report says of it, and the
// encoder it needs in ctx.
void plan_code_check(const SourceInfo& si, const Linearizer& lin, VerifyReport& r,
                     MeasureContext& ctx) {
    if (si.is_float) {
        r.code_match_note = "float source: no codes to match";
    } else if (si.bits != 8 && si.bits != 16) {
        r.code_match_note =
            std::to_string(si.bits) + "-bit source: only 8- and 16-bit codes are checked";
    } else if (!lin.can_encode()) {
        r.code_match_note = "the config cannot invert the transform of '" + lin.input_space() + "'";
    } else {
        ctx.encoder = &lin;
        r.code_match_note =
            "re-encoded through the config's inverse transform to '" + lin.input_space() + "'";
    }
    r.code_match_available = ctx.encoder != nullptr;
    ctx.max_code = si.bits == 16 ? 65535.0 : 255.0;
}

// The source, opened and checked before any pixel is read, with the linearisation the file
// records (or the one given).
std::unique_ptr<ImageSource> open_source(const std::string& exr_path, const SpectralExrInfo& info,
                                         const VerifySettings& s, const Recorded& recorded,
                                         VerifyReport& r, Linearizer& lin, MeasureContext& ctx) {
    auto src = ImageSource::open(s.source, s.max_pixels);
    const SourceInfo& si = src->info();
    if (si.width != info.width || si.height != info.height)
        throw Error(exr_path + ": data window " + std::to_string(info.width) + "x" +
                    std::to_string(info.height) + " differs from the source's " +
                    std::to_string(si.width) + "x" + std::to_string(si.height) + " (" + s.source +
                    ")");
    const std::string config = choose_config(recorded, s, r);
    const std::string rec_space = recorded(provenance_key::kInputColorSpace);
    ColourRequest req{s.data_dir, config, s.colorspace.empty() ? rec_space : s.colorspace, s.source,
                      si.colour};
    lin = Linearizer::make(req);
    // What the config does to the source, against what it did at the bake: a comment or a colour
    // space the file does not use is no change.
    const std::string rec_transform = recorded(provenance_key::kColorTransform);
    if (!rec_transform.empty() && lin.input_space() == rec_space &&
        lin.transform_id() != rec_transform)
        r.warnings.push_back("the OCIO config " + lin.config_path() + " transforms '" + rec_space +
                             "' otherwise than the one this file was baked with (" +
                             provenance_key::kColorTransform + ")");
    if (!s.colorspace.empty() && !rec_space.empty() && lin.input_space() != rec_space)
        r.warnings.push_back("--colorspace '" + s.colorspace + "' ('" + lin.input_space() +
                             "') overrides the file's '" + rec_space + "' (" +
                             provenance_key::kInputColorSpace + ")");
    r.compared = true;
    r.source = s.source;
    r.source_colorspace = lin.input_space();
    r.source_colorspace_how = s.colorspace.empty() && !rec_space.empty()
                                  ? std::string("the file's ") + provenance_key::kInputColorSpace
                                  : lin.how_chosen();
    r.source_bits = si.bits;
    r.source_float = si.is_float;
    ctx.compare = true;
    ctx.source_associated = si.alpha == AlphaKind::Associated;
    plan_code_check(si, lin, r, ctx);
    return src;
}

}  // namespace

VerifyReport verify_file(const std::string& exr_path, const VerifySettings& s) {
    const auto t0 = std::chrono::steady_clock::now();
    SpectralReader reader(exr_path);  // throws "<path>: <cause>"
    const SpectralExrInfo& info = reader.info();
    // A truncated file can still decode its first level (verify reads level 0): its other levels,
    // or later chunks, are missing.
    if (!info.complete)
        throw Error(
            exr_path +
            ": incomplete: chunks of the pixel data are missing (a truncated or interrupted file)");

    VerifyReport r = describe_file(exr_path, info);
    const Recorded recorded(info, r.warnings);
    read_recorded_settings(recorded, s, r);
    r.alpha = reader.alpha();  // "associated" is OpenEXR's convention when nothing says otherwise
    if (const std::string a = recorded(provenance_key::kAlpha);
        info.alpha && !a.empty() && a != to_string(AlphaKind::Associated) &&
        a != to_string(AlphaKind::Unassociated))
        r.warnings.push_back(std::string(provenance_key::kAlpha) + " '" +
                             printable_excerpt(a, 200) +
                             "' is neither associated nor unassociated: A is taken as associated "
                             "(OpenEXR's convention)");

    MeasureContext ctx;
    const Colorimetry col = file_colorimetry(exr_path, info, s, r, ctx);
    const Eigen::Matrix3Xd wrgb = col.rgb_weights();
    std::unique_ptr<ImageSource> src;
    Linearizer lin;
    if (!s.source.empty()) {
        // The source the header records, changed since the bake, is not compared: the file is
        // stale, whatever the colours would say. Another file given with --source (a conversion
        // of the source, say) is compared as given.
        if (is_recorded_source(exr_path, info, s.source))
            check_source_identity(s.source, recorded, r);
        if (!r.source_changed) {
            try {
                src = open_source(exr_path, info, s, recorded, r, lin, ctx);
            } catch (const Error& e) {
                throw VerifyError(e.what(), r.warnings);
            }
        }
    }

    try {
        // Whole chunks (or tile rows) per band when they fit the budget, so that no chunk is
        // decoded twice; for very wide files a band may be part of a chunk (OpenEXR keeps the
        // decoded chunk).
        const int band_rows = reader.band_rows(s.band_bytes);
        r.band_rows = band_rows;
        ctx.w = static_cast<size_t>(info.width);
        ctx.plane = ctx.w * static_cast<size_t>(band_rows);
        ctx.bins = r.bins;
        ctx.x0 = info.data_x0;
        ctx.y0 = info.data_y0;
        ctx.wrgb = wrgb.data();
        ctx.rgb_to_xyz = col.rgb_to_xyz;
        ctx.xyz_to_rgb = col.xyz_to_rgb;
        ctx.white = col.white_xyz;
        ctx.has_alpha = info.alpha;
        ctx.associated = r.alpha == AlphaKind::Associated;
        if (ctx.associated && info.alpha) {
            ctx.straight_tol = straight_tolerances(r);
            r.straight_range = true;
        }
        measure_file(reader, src.get(), lin, ctx, band_rows, s, r);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(exr_path + ": cannot read the pixels: " + e.what());
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

std::string recorded_source(const std::string& exr,
                            const std::vector<std::pair<std::string, std::string>>& attributes) {
    namespace fs = std::filesystem;
    std::string given, absolute, from_output;
    for (const auto& [k, v] : attributes) {
        if (k == provenance_key::kSource) given = v;
        if (k == provenance_key::kSourceAbsolute) absolute = v;
        if (k == provenance_key::kSourceFromOutput) from_output = v;
    }
    if (given.empty() && absolute.empty() && from_output.empty())
        throw Error(exr + ": the header records no " + provenance_key::kSource);
    std::vector<std::string> tried;
    if (!from_output.empty())
        tried.push_back((fs::path(exr).parent_path() / from_output).lexically_normal().string());
    if (!absolute.empty()) tried.push_back(absolute);
    if (!given.empty()) tried.push_back(given);
    for (const auto& p : tried) {
        std::error_code ec;
        if (fs::exists(p, ec)) return p;
    }
    std::string list;
    for (const auto& p : tried) list += (list.empty() ? "" : ", ") + quote_path(p);
    throw Error(exr + ": the source it records is not found (tried " + list + ")");
}

std::vector<VerifyOutcome> verify_files(const std::vector<std::string>& files,
                                        const VerifySettings& s, const VerifyGates& g,
                                        bool source_from_header, int jobs) {
    std::vector<VerifyOutcome> outcomes(files.size());
    // Per job: the file's measuring ranges and its band producer, as many threads as they had of
    // their own before the pool.
    const int threads = std::min(s.threads > 0 ? s.threads : hardware_threads(), thread_budget());
    TaskPool::shared().reserve(std::max(1, jobs) * (threads + 1) - 1);
    TaskPool::shared().parallel_for(files.size(), jobs, [&](size_t i) {
        VerifyOutcome& o = outcomes[i];
        VerifySettings fs = s;
        try {
            if (source_from_header)
                fs.source = recorded_source(files[i], read_spectral_exr_info(files[i]).attributes);
            o.report = verify_file(files[i], fs);
            o.failures = gate_failures(o.report, g);
            o.readable = true;
        } catch (const VerifyError& e) {
            o.error = e.what();
            o.warnings = e.warnings;
        } catch (const Error& e) {
            o.error = e.what();
        } catch (const std::exception& e) {
            o.error = files[i] + ": " + e.what();
        }
    });
    return outcomes;
}

}  // namespace spectex
