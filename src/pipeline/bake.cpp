#include "pipeline/bake.h"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>

#include "base/error.h"
#include "base/half.h"
#include "base/task_pool.h"
#include "base/text.h"
#include "io/atomic_file.h"
#include "io/file_identity.h"
#include "io/image_source.h"
#include "io/linearizer.h"
#include "io/ocio_config.h"
#include "io/provenance_keys.h"
#include "io/rebuild_record.h"
#include "io/source_identity.h"
#include "pipeline/bake_request.h"
#include "pipeline/pixel_policy.h"
#include "spectex/version.h"
#include "spectral/expand.h"
#include "spectral/precision.h"

namespace spectex {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// Bytes of expanded spectral samples held per strip: bounds memory whatever the bin count.
constexpr size_t kStripBudget = 32u << 20;

// Refuses an output that is the input, or a hard or symbolic link to it (by identity).
void check_not_input(const std::string& input, const std::string& output) {
    const std::optional<FileId> in = file_id(input);  // a missing input: the reader reports it
    if (in && in == file_id(output))
        throw Error(output +
                    ": output is the input file (or a link to it); refusing to overwrite it");
}

// Area-weighted box filter from sw x sh to dw x dh (dw <= sw, dh <= sh): every destination pixel
// averages the source area it covers, fractional edges included (exact for odd sizes too).
std::vector<float> box_downsample(const std::vector<float>& src, int sw, int sh, int dw, int dh) {
    auto weights = [](int s, int d) {
        // For each destination index: list of (source index, weight), weights summing to 1.
        std::vector<std::vector<std::pair<int, double>>> w(static_cast<size_t>(d));
        const double scale = static_cast<double>(s) / d;
        for (int i = 0; i < d; ++i) {
            double a = i * scale, b = (i + 1) * scale;
            for (int j = static_cast<int>(std::floor(a));
                 j < std::min(s, static_cast<int>(std::ceil(b))); ++j) {
                double cover = std::min(b, j + 1.0) - std::max(a, static_cast<double>(j));
                if (cover > 0) w[static_cast<size_t>(i)].emplace_back(j, cover / scale);
            }
        }
        return w;
    };
    auto wx = weights(sw, dw), wy = weights(sh, dh);
    std::vector<float> tmp(static_cast<size_t>(dw) * static_cast<size_t>(sh)),
        out(static_cast<size_t>(dw) * static_cast<size_t>(dh));
    for (int y = 0; y < sh; ++y)
        for (int x = 0; x < dw; ++x) {
            double acc = 0;
            for (auto [j, wt] : wx[static_cast<size_t>(x)])
                acc += wt * src[static_cast<size_t>(y) * sw + j];
            tmp[static_cast<size_t>(y) * dw + x] = static_cast<float>(acc);
        }
    for (int y = 0; y < dh; ++y)
        for (int x = 0; x < dw; ++x) {
            double acc = 0;
            for (auto [j, wt] : wy[static_cast<size_t>(y)])
                acc += wt * tmp[static_cast<size_t>(j) * dw + x];
            out[static_cast<size_t>(y) * dw + x] = static_cast<float>(acc);
        }
    return out;
}

std::string join_lambda(const std::vector<double>& l) {
    std::string s;
    for (double v : l) s += (s.empty() ? "" : " ") + format_wavelength(v);
    return s;
}

}  // namespace

int strip_rows(size_t row_bytes, int lines_per_chunk, bool whole_chunks, int height) {
    int rows = std::max(1, static_cast<int>(kStripBudget / std::max<size_t>(row_bytes, 1)));
    if (whole_chunks) rows = std::max(1, rows / lines_per_chunk) * lines_per_chunk;
    return std::min(rows, height);
}

namespace {

// What the source's shape means for the bake, as notes for the user.
void note_source_shape(const SourceInfo& info, BakeResult& res) {
    if (info.miplevels > 1)
        res.notes.push_back("input has " + std::to_string(info.miplevels) +
                            " MIP levels: the first was used");
    if (info.subimages > 1)
        res.notes.push_back("input has " + std::to_string(info.subimages) +
                            " subimages: the first was used");
    res.notes.insert(res.notes.end(), info.notes.begin(), info.notes.end());
    if (info.channels > 4)
        res.notes.push_back("input has " + std::to_string(info.channels) +
                            " channels: only RGB(A) were used");
}

// The colour space chosen for the file and how, for the summary and the JSON record; what the file
// states that the config cannot name is a warning of the file (file_warnings: shown under -q too).
void record_colour(const SourceInfo& info, const Linearizer& lin, BakeResult& res) {
    res.notes.insert(res.notes.end(), lin.warnings().begin(), lin.warnings().end());
    res.colorspace = lin.input_space();
    res.colorspace_how = lin.how_chosen();
    res.colorspace_rule = lin.file_rule();
    res.config = lin.config_path();
    res.config_from = lin.config_from();
    res.integer_to_linear_by_default_rule =
        !info.is_float && lin.by_default_rule() && lin.scene_linear();
}

// The spectex:* header attributes, in the order that is part of the output's bytes.
std::vector<std::pair<std::string, std::string>> header_attributes(
    const BakeSettings& s, const std::string& input, const std::string& output,
    const Linearizer& lin, const std::string& colour_tags, bool has_alpha,
    const SpectralMethod& method, const SourceIdentity& identity, int zip_level) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path source = fs::absolute(input, ec).lexically_normal();
    const fs::path out_dir = fs::absolute(output, ec).lexically_normal().parent_path();
    std::vector<std::pair<std::string, std::string>> a = {
        {provenance_key::kVersion, SPECTEX_VERSION},
        {provenance_key::kCommandLine, file_command_line(input, output, s.file_options)},
        {provenance_key::kSource, input},
    };
    // The method's own attributes stand where the basis' always stood (the order is part of the
    // bytes).
    for (const auto& [fact, value] : method.provenance())
        a.push_back({method_fact_key(fact), value});
    a.insert(a.end(),
             {
                 {provenance_key::kSourceAbsolute, source.string()},
                 {provenance_key::kSourceFromOutput, source.lexically_relative(out_dir).string()},
                 {provenance_key::kWavelengths, s.grid.describe()},
                 {provenance_key::kWavelengthList, join_lambda(s.grid.lambda)},
                 {provenance_key::kObserver, s.observer},
                 {provenance_key::kIlluminant, s.illuminant},
                 {provenance_key::kInputColorSpace, lin.input_space()},
                 {provenance_key::kInputColorSpaceFrom, lin.how_chosen()},
                 {provenance_key::kInputColorSpaceMetadata, colour_tags},
                 {provenance_key::kConfig,
                  std::filesystem::absolute(lin.config_path()).lexically_normal().string()},
                 {provenance_key::kConfigFrom, lin.config_from()},
                 {provenance_key::kConfigName, lin.config_name()},
                 {provenance_key::kConfigChecksum, config_checksum(lin.config_path())},
                 {provenance_key::kColorTransform, lin.transform_id()},
                 {provenance_key::kAlpha, to_string(has_alpha ? s.alpha : AlphaKind::None)},
                 {provenance_key::kOutOfRange, to_string(s.range)},
                 {provenance_key::kNan, to_string(s.nan)},
                 {provenance_key::kZipLevel, std::to_string(zip_level)},
                 {provenance_key::kHalfRounding,
                  s.type == SampleType::Half ? (s.colour_rounding ? "colour" : "nearest") : "n/a"},
                 {provenance_key::kSettingsHash, s.settings_hash},
                 // The source's identity, for --update (io/source_identity.h); the hash is patched
                 // in once the source has been decoded (and so hashed).
                 {provenance_key::kSourceSize, identity.size_text()},
                 {provenance_key::kSourceMtime, identity.mtime_text()},
                 {provenance_key::kSourceHash, source_hash_placeholder()},
             });
    if (s.compression.lossy_for(s.type == SampleType::Half))
        a.push_back({provenance_key::kLossyCompression,
                     s.compression.name + " (" + s.compression.lossy_text() + ")"});
    if (!s.plan.lights.empty()) {
        a.push_back({provenance_key::kPlanLights, s.plan.lights});
        a.push_back({provenance_key::kPlanMaxDe, s.plan.max_de});
        a.push_back({provenance_key::kPlanReconstruction, s.plan.reconstruction});
        a.push_back({provenance_key::kPlanRange, s.plan.range});
        a.push_back({provenance_key::kPlanWorstDe, s.plan.worst_de});
        if (s.plan.nonuniform) a.push_back({provenance_key::kPlanGrids, "uniform and non-uniform"});
    }
    if (!s.precision.bits.empty()) {
        a.push_back({provenance_key::kPrecision, "auto"});
        a.push_back({provenance_key::kPrecisionMaxDe, s.precision.max_de});
        a.push_back({provenance_key::kPrecisionLights, s.precision.lights});
        a.push_back({provenance_key::kPrecisionBits, format_precision_bits(s.precision.bits)});
        a.push_back({provenance_key::kPrecisionWorstDe, s.precision.worst_de});
        if (!s.precision.worst_code.empty())
            a.push_back({provenance_key::kPrecisionWorstCode, s.precision.worst_code});
        a.push_back({provenance_key::kPrecisionSample, s.precision.sample});
    }
    // Last: the largest (the default's table is 33 KB of text), after everything a person reads.
    if (s.bin_rgb.size() == 3 * s.grid.size())
        for (auto& kv : rebuild_attributes(method.rebuild_table(), s.bin_rgb,
                                           join_lambda(s.grid.lambda), s.type == SampleType::Half))
            a.push_back(std::move(kv));
    return a;
}

// The deflate level of a file: the one asked, or by its size (DefaultBake).
int zip_level_for(const BakeSettings& s, const SourceInfo& info) {
    if (s.zip_level > 0) return s.zip_level;
    const uint64_t pixels = static_cast<uint64_t>(std::max(info.width, 0)) *
                            static_cast<uint64_t>(std::max(info.height, 0));
    return pixels <= DefaultBake::small_pixels ? DefaultBake::small_zip_level
                                               : DefaultBake::large_zip_level;
}

// The output file's layout: the source's windows, the grid, types, tiles and header.
SpectralExrLayout output_layout(const BakeSettings& s, const SourceInfo& info, int zip_level,
                                std::vector<std::pair<std::string, std::string>> attributes) {
    SpectralExrLayout layout;
    static_cast<PixelWindows&>(layout) = info;
    layout.lambda = s.grid.lambda;
    layout.type = s.type;
    layout.alpha = info.alpha != AlphaKind::None;
    // Half holds every 8-bit alpha exactly enough to re-encode it; 16-bit and float alphas need
    // float.
    layout.alpha_type =
        (s.type == SampleType::Half && (info.bits <= 8 || (info.is_float && info.bits == 16)))
            ? SampleType::Half
            : SampleType::Float;
    layout.preview = s.preview;
    layout.compression = s.compression;
    layout.zip_level = zip_level;
    layout.attributes = std::move(attributes);
    layout.threads = s.threads;
    layout.tile_width = s.mipmap && s.tile_width <= 0 ? 64 : s.tile_width;
    layout.tile_height = s.mipmap && s.tile_height <= 0 ? 64 : s.tile_height;
    layout.mipmap = s.mipmap;
    layout.wrapmodes = s.wrapmodes;
    return layout;
}

// The pixel stages of one file between the reader and the writer: read and police rows into
// linear (premultiplied) planes, expand planes to bins, hand them to the writer; and the two
// orders they run in (scanlines with two strips in flight, or a MIP pyramid).
//
// Associated alpha: every method expands the straight colour and multiplies its spectrum by alpha
// before rounding: a lattice's spectrum of a * rgb is not a times its spectrum of rgb
// (SpectralMethod::is_linear), and divided by alpha it left [0, 1]; and the colour-aware rounding
// to half then holds the colour divided by alpha, as it is read back (round_spectra_to_bits). A
// linear method (the basis) written as float expands the premultiplied colour: the same spectra,
// faster.
class PixelStages {
  public:
    PixelStages(const std::string& input, const BakeSettings& s, const SpectralMethod& method,
                ImageSource& src, const Linearizer& lin, SpectralExrWriter& writer,
                const SpectralExrLayout& layout, BakeResult& res, BakeProgress* progress)
        : input_(input),
          s_(s),
          method_(method),
          src_(src),
          lin_(lin),
          writer_(writer),
          res_(res),
          progress_(progress),
          info_(src.info()),
          has_alpha_(info_.alpha != AlphaKind::None),
          premultiply_(has_alpha_ && s.alpha == AlphaKind::Associated),
          spectra_premultiplied_(premultiply_ &&
                                 (!method.is_linear() || s.type == SampleType::Half)),
          alpha_as_half_(has_alpha_ && layout.alpha_type == SampleType::Half),
          policy_{info_.alpha == AlphaKind::Associated, s.nan, s.range,
                  s.type == SampleType::Half ? kHalfMax : 0.0f},
          rgb_weight_(s.half_rgb_weight),
          feedback_(rgb_weight_.empty() ? nullptr : &rgb_weight_),
          bins_(static_cast<size_t>(method.bins())),
          w_(static_cast<size_t>(info_.width)),
          tiled_(layout.tile_width > 0),
          tile_height_(layout.tile_height) {
        const size_t es = s.type == SampleType::Half ? 2 : 4;
        const int chunk = tiled_ ? layout.tile_height : s.compression.lines_per_chunk;
        size_t row_bytes = w_ * bins_ * es;
        strip_ = strip_rows(row_bytes, chunk, tiled_ || std::string(writer.writer_name()) != "core",
                            info_.height);
    }

    void run() {
        if (progress_) {
            long rows = info_.height;
            if (s_.mipmap) {
                rows = 0;
                for (int l = 0; l < writer_.levels(); ++l) rows += writer_.level_height(l);
            }
            progress_->rows_total = rows;
        }
        if (s_.mipmap)
            write_mipmapped();
        else
            write_scanlines();
    }

  private:
    struct Strip {
        std::vector<float> r, g, b, a;
        std::vector<float> sr, sg, sb;  // straight colour (spectra_premultiplied_ only)
        std::vector<uint16_t> half;
        std::vector<float> flt;
        int y0 = 0, y1 = 0;
    };

    // A batch told to stop (SIGTERM, SIGINT, SIGHUP: io/atomic_file.h) stops this file at its next
    // strip; the output's temporary file is removed as the exception leaves bake_file.
    void stop_if_requested() const {
        if (const int sig = termination_requested()) throw BakeInterrupted(input_, sig);
    }

    // Reads rows [y0, y1) and leaves linear, policed, (premultiplied) planes in r, g, b, a, and
    // the straight colour in sr, sg, sb when they are given.
    void read_rows(int y0, int y1, float* r, float* g, float* b, float* a, float* sr = nullptr,
                   float* sg = nullptr, float* sb = nullptr) {
        stop_if_requested();
        const size_t n = w_ * static_cast<size_t>(y1 - y0);
        rgba_.resize(n * 4);
        auto t_read = Clock::now();
        src_.read_rgba(y0, y1, rgba_.data());
        res_.stages.read += since(t_read);
        auto t_colour = Clock::now();
        const PolicedCounts counts = police_rgba(rgba_.data(), n, lin_, policy_, input_, w_, y0);
        res_.replaced_pixels += counts.replaced;
        res_.clamped_pixels += counts.clamped;
        res_.clamped_excursion = std::max(res_.clamped_excursion, counts.clamped_excursion);
        for (size_t i = 0; i < n; ++i) {
            const float* p = &rgba_[4 * i];
            const float al = alpha_as_half_ ? as_stored_half(p[3]) : p[3];
            float k = premultiply_ ? al : 1.0f;
            r[i] = p[0] * k;
            g[i] = p[1] * k;
            b[i] = p[2] * k;
            if (has_alpha_) a[i] = al;
            if (sr) sr[i] = p[0], sg[i] = p[1], sb[i] = p[2];
        }
        res_.stages.colour += since(t_colour);
    }

    // Expands n pixels into `half` or `flt` (by the output type); returns the planes. With
    // alpha (spectra_premultiplied_), r, g, b are the straight colour and every spectrum is
    // multiplied by its alpha before it is rounded. Runs on --threads threads, in runs of
    // kExpandRun pixels: every pixel's spectrum and rounding are its own, so the bytes are the
    // same whatever the threads; the producer (one task) would otherwise leave the cores the
    // writer does not fill idle while it expands the next strip.
    const void* expand(const float* r, const float* g, const float* b, const float* alpha, size_t n,
                       std::vector<uint16_t>& half, std::vector<float>& flt) const {
        constexpr size_t kExpandRun = 16384;
        const bool as_half = s_.type == SampleType::Half;
        if (as_half)
            half.resize(n * bins_);
        else
            flt.resize(n * bins_);
        const size_t runs = (n + kExpandRun - 1) / kExpandRun;
        TaskPool::shared().parallel_for(runs, std::max(1, s_.threads), [&](size_t k) {
            const size_t i0 = k * kExpandRun, len = std::min(kExpandRun, n - i0);
            expand_run(r + i0, g + i0, b + i0, alpha ? alpha + i0 : nullptr, len,
                       as_half ? half.data() + i0 : nullptr, as_half ? nullptr : flt.data() + i0,
                       n);
        });
        return as_half ? static_cast<const void*>(half.data())
                       : static_cast<const void*>(flt.data());
    }

    // One run of expand(): n pixels into planes `stride` apart at h (half) or f (float).
    void expand_run(const float* r, const float* g, const float* b, const float* alpha, size_t n,
                    uint16_t* h, float* f, size_t stride) const {
        if (alpha) {
            if (h)
                (void)expand_half_premultiplied(method_, r, g, b, alpha, n, h, stride, feedback_,
                                                s_.precision.bits);
            else
                expand_float_premultiplied(method_, r, g, b, alpha, n, f, stride);
        } else if (!h) {
            method_.expand_float(r, g, b, n, f, stride);
        } else if (s_.precision.bits.empty()) {
            method_.expand_half(r, g, b, n, h, stride, feedback_);
        } else {
            (void)expand_half_bits(method_, r, g, b, n, h, stride, feedback_, s_.precision.bits);
        }
    }

    // Two strips in flight: while strip k is packed and handed to the writer's compression tasks,
    // a pool task decodes, linearises and expands strip k+1, so those stages hide under the
    // encoder. The producer alone touches the reader and the counters.
    void write_scanlines() {
        std::array<Strip, 2> strips;
        const size_t count = static_cast<size_t>((info_.height + strip_ - 1) / strip_);
        res_.stages.producer_wait += produce_consume_strips(
            count,
            [&](size_t k, int slot) {
                produce(strips[static_cast<size_t>(slot)], static_cast<int>(k) * strip_);
            },
            [&](size_t, int slot) { consume(strips[static_cast<size_t>(slot)]); });
    }

    void produce(Strip& st, int y0) {
        st.y0 = y0;
        st.y1 = std::min(info_.height, y0 + strip_);
        const size_t n = w_ * static_cast<size_t>(st.y1 - st.y0);
        st.r.resize(n);
        st.g.resize(n);
        st.b.resize(n);
        st.a.resize(has_alpha_ ? n : 0);
        for (auto* p : {&st.sr, &st.sg, &st.sb}) p->resize(spectra_premultiplied_ ? n : 0);
        const bool s = spectra_premultiplied_;  // expand the straight colour, times A
        read_rows(st.y0, st.y1, st.r.data(), st.g.data(), st.b.data(), st.a.data(),
                  s ? st.sr.data() : nullptr, s ? st.sg.data() : nullptr,
                  s ? st.sb.data() : nullptr);
        auto t_expand = Clock::now();
        expand(s ? st.sr.data() : st.r.data(), s ? st.sg.data() : st.g.data(),
               s ? st.sb.data() : st.b.data(), s ? st.a.data() : nullptr, n, st.half, st.flt);
        res_.stages.expand += since(t_expand);
    }

    void consume(const Strip& st) {
        const size_t n = w_ * static_cast<size_t>(st.y1 - st.y0);
        const void* planes = s_.type == SampleType::Half ? static_cast<const void*>(st.half.data())
                                                         : static_cast<const void*>(st.flt.data());
        if (tiled_)
            writer_.write_level_rows(0, st.y0, st.y1 - st.y0, planes, n, st.a.data(), st.r.data(),
                                     st.g.data(), st.b.data());
        else
            writer_.write_rows(st.y1 - st.y0, planes, n, st.a.data(), st.r.data(), st.g.data(),
                               st.b.data());
        if (progress_) progress_->rows_done += st.y1 - st.y0;
    }

    // MIP-mapped: every level is filtered on the linear (and premultiplied) RGBA and expanded
    // afterwards; memory is the RGBA pyramid, not N bins. For a linear method that is the filter
    // of the spectra. For any other, a texel holds the method's spectrum of its filtered straight
    // colour (filtered premultiplied colour / filtered alpha) times its filtered alpha: exact
    // under the method's light for the filtered colour and within [0, 1] once divided by alpha,
    // as level 0 is; under other lights it differs from the filter of level 0's spectra by the
    // method's curvature between the texels filtered together.
    //
    // Straight output (--alpha unassociated): level 0's planes are the straight colour, and a
    // level's is the filter of the premultiplied colour divided by the filtered alpha (as maketx
    // filters unassociated alpha): what cannot be seen is not filtered in. A texel with nothing
    // seen keeps the plain filter of the straight colour (a cut-out's hidden colour, as level 0
    // keeps it).
    void write_mipmapped() {
        const size_t n0 = w_ * static_cast<size_t>(info_.height);
        std::array<std::vector<float>, 4> level;
        for (int c = 0; c < (has_alpha_ ? 4 : 3); ++c) level[static_cast<size_t>(c)].resize(n0);
        for (int y0 = 0; y0 < info_.height; y0 += strip_) {
            const int y1 = std::min(info_.height, y0 + strip_);
            const size_t off = w_ * static_cast<size_t>(y0);
            read_rows(y0, y1, level[0].data() + off, level[1].data() + off, level[2].data() + off,
                      has_alpha_ ? level[3].data() + off : nullptr);
        }
        const bool straight_out = has_alpha_ && !premultiply_;
        std::array<std::vector<float>, 3> weighted;  // straight_out: colour times alpha
        if (straight_out)
            for (size_t c = 0; c < 3; ++c) {
                weighted[c].resize(n0);
                for (size_t i = 0; i < n0; ++i) weighted[c][i] = level[c][i] * level[3][i];
            }
        std::vector<uint16_t> half;
        std::vector<float> flt;
        int lw = info_.width, lh = info_.height;
        for (int l = 0; l < writer_.levels(); ++l) {
            if (l > 0) {
                const int nw = writer_.level_width(l), nh = writer_.level_height(l);
                for (auto& p : level)
                    if (!p.empty()) p = box_downsample(p, lw, lh, nw, nh);
                for (auto& p : weighted)
                    if (!p.empty()) p = box_downsample(p, lw, lh, nw, nh);
                lw = nw;
                lh = nh;
                if (straight_out) {
                    const size_t n = static_cast<size_t>(lw) * static_cast<size_t>(lh);
                    for (size_t i = 0; i < n; ++i) {
                        const float a = level[3][i];
                        if (!(a > 0.0f)) continue;
                        for (size_t c = 0; c < 3; ++c) level[c][i] = weighted[c][i] / a;
                    }
                }
            }
            for (int y0 = 0; y0 < lh; y0 += tile_height_) {
                const int y1 = std::min(lh, y0 + tile_height_);
                const size_t off = static_cast<size_t>(lw) * static_cast<size_t>(y0);
                const size_t n = static_cast<size_t>(lw) * static_cast<size_t>(y1 - y0);
                const float *r = level[0].data() + off, *g = level[1].data() + off,
                            *b = level[2].data() + off;
                const float* filtered = has_alpha_ ? level[3].data() + off : nullptr;
                // The alpha the file stores (level 0's already is: read_rows). The straight colour
                // is divided by the filtered alpha itself: by the stored one, an opaque colour's
                // channel of 1 could come out above 1.
                const float* a = filtered;
                if (a && alpha_as_half_ && l > 0) {
                    stored_alpha_.resize(n);
                    for (size_t i = 0; i < n; ++i) stored_alpha_[i] = as_stored_half(a[i]);
                    a = stored_alpha_.data();
                }
                stop_if_requested();
                const void* planes = nullptr;
                if (spectra_premultiplied_) {
                    straighten(r, g, b, filtered, n);
                    planes = expand(straight_[0].data(), straight_[1].data(), straight_[2].data(),
                                    a, n, half, flt);
                } else {
                    planes = expand(r, g, b, nullptr, n, half, flt);
                }
                writer_.write_level_rows(l, y0, y1 - y0, planes, n, a, r, g, b);
                if (progress_) progress_->rows_done += y1 - y0;
            }
        }
    }

    // straight_ = premultiplied colour / alpha (0 where alpha is 0: its spectrum is multiplied by
    // 0). A filtered level's colour has no straight value to keep, so it is divided back.
    void straighten(const float* r, const float* g, const float* b, const float* a, size_t n) {
        for (auto& p : straight_) p.resize(n);
        for (size_t i = 0; i < n; ++i) {
            const bool seen = a[i] > 0.0f;
            straight_[0][i] = seen ? r[i] / a[i] : 0.0f;
            straight_[1][i] = seen ? g[i] / a[i] : 0.0f;
            straight_[2][i] = seen ? b[i] / a[i] : 0.0f;
        }
    }

    const std::string& input_;
    const BakeSettings& s_;
    const SpectralMethod& method_;
    ImageSource& src_;
    const Linearizer& lin_;
    SpectralExrWriter& writer_;
    BakeResult& res_;
    BakeProgress* progress_;
    const SourceInfo& info_;
    const bool has_alpha_, premultiply_;
    const bool spectra_premultiplied_;  // premultiply_, but a linear method's float output
    // Alpha stored as half: every alpha is taken as the half the file stores before anything is
    // multiplied by it, so that T / A read back is the spectrum the rounding held (the float alpha
    // of an 8-bit code differs from its half by up to 2^-11 of itself, a shift of every channel
    // that was a third of the budget the coarse rounding leaves).
    const bool alpha_as_half_;
    const PixelPolicy policy_;
    const std::vector<float>& rgb_weight_;  // the batch's (BakeSettings::half_rgb_weight)
    const std::vector<float>* feedback_;
    const size_t bins_, w_;
    const bool tiled_;
    const int tile_height_;
    int strip_ = 1;
    std::vector<float> rgba_;
    std::array<std::vector<float>, 3> straight_;
    std::vector<float> stored_alpha_;  // a filtered level's alpha as the file stores it

    static float as_stored_half(float v) { return half_to_float(float_to_half(v)); }
};

// After the last pixel: close the file, patch in the source's hash (known once it was decoded),
// note the writer's timing and the size, and rename the file into place.
void finish_output(SpectralExrWriter& writer, AtomicFile& out, ImageSource& src,
                   const std::string& output, BakeResult& res) {
    auto t_finish = Clock::now();
    writer.finish();
    patch_string_attribute(out.fd(), provenance_key::kSourceHash, source_hash_placeholder(),
                           src.content_hash(), output);
    res.stages.finish = since(t_finish);
    const auto wt = writer.timing();
    res.stages.pack = wt.pack_seconds;
    res.stages.encoder_wait = wt.wait_seconds;
    res.stages.compress_cpu = wt.compress_seconds;
    res.stages.writer = writer.writer_name();
    struct stat st;
    if (::fstat(out.fd(), &st) == 0) res.bytes = static_cast<uint64_t>(st.st_size);
    out.commit();
}

}  // namespace

// The stages of one file, in order: check the names, open the source, choose its colour space,
// lay out the output, run the pixel stages, finish the file.
BakeResult bake_file(const std::string& input, const std::string& output, const BakeSettings& s,
                     BakeProgress* progress) {
    auto t0 = std::chrono::steady_clock::now();
    BakeResult res;
    res.input = input;
    res.output = output;
    check_not_input(input, output);
    const SpectralMethod& method = *s.method;
    if (!same_wavelengths(method.lambda(), s.grid.lambda))
        throw Error("the " + method.name() + " method is not on the output grid " +
                    s.grid.describe());
    const bool colour_rounding = s.type == SampleType::Half && s.colour_rounding;
    if (s.half_rgb_weight.size() != (colour_rounding ? 3 * s.grid.size() : 0))
        throw Error(
            "the settings' colour-rounding weights are not those of the output grid "
            "(settings not made by prepare_bake)");

    auto src = ImageSource::open(input, s.max_pixels);
    const SourceInfo& info = src->info();
    note_source_shape(info, res);

    Linearizer lin =
        Linearizer::make(ColourRequest{s.data_dir, s.config, s.colorspace, input, info.colour});
    if (!info.is_float) lin.use_code_table(info.bits);
    record_colour(info, lin, res);

    const int zip_level = zip_level_for(s, info);
    const SpectralExrLayout layout = output_layout(
        s, info, zip_level,
        header_attributes(s, input, output, lin, colour_tags_record(info.colour),
                          info.alpha != AlphaKind::None, method, src->identity(), zip_level));
    AtomicFile out(output);
    SpectralExrWriter writer(out, layout);
    PixelStages(input, s, method, *src, lin, writer, layout, res, progress).run();
    finish_output(writer, out, *src, output, res);

    res.pixels = static_cast<uint64_t>(info.width) * static_cast<uint64_t>(info.height);
    res.bins = method.bins();
    res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return res;
}

std::string file_command_line(const std::string& input, const std::string& output,
                              const std::string& options) {
    if (!input.empty() && input[0] == '-')
        return "spectex bake -o " + quote_path(output) + options + " -- " + quote_path(input);
    return "spectex bake " + quote_path(input) + " -o " + quote_path(output) + options;
}

}  // namespace spectex
