#include "pipeline/bake.h"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "io/atomic_file.h"
#include "io/image_source.h"
#include "io/linearizer.h"
#include "spectex/version.h"
#include "spectral/error.h"
#include "spectral/expand.h"

namespace spectex {

namespace {

// Bytes of expanded spectral samples held per strip: bounds memory whatever the bin count.
constexpr size_t kStripBudget = 32u << 20;

std::string real_path(const std::string& p) {
    char buf[PATH_MAX];
    return ::realpath(p.c_str(), buf) ? std::string(buf) : std::string();
}

// Refuses an output that is the input, or a hard or symbolic link to it.
void check_not_input(const std::string& input, const std::string& output) {
    struct stat si, so;
    if (::stat(input.c_str(), &si) != 0) return;  // the reader reports a missing input
    if (::stat(output.c_str(), &so) == 0 && si.st_dev == so.st_dev && si.st_ino == so.st_ino)
        throw Error(output + ": output is the input file (or a link to it); refusing to overwrite it");
    std::string ri = real_path(input), ro = real_path(output);
    if (!ri.empty() && ri == ro)
        throw Error(output + ": output is the input file; refusing to overwrite it");
}

std::string join_lambda(const std::vector<double>& l) {
    std::string s;
    for (double v : l) s += (s.empty() ? "" : " ") + format_wavelength(v);
    return s;
}

}  // namespace

std::string to_string(RangePolicy p) {
    return p == RangePolicy::Clamp ? "clamp" : p == RangePolicy::Keep ? "keep" : "error";
}
std::string to_string(NanPolicy p) { return p == NanPolicy::Replace ? "replace" : "error"; }

BakeResult bake_file(const std::string& input, const std::string& output, const BakeSettings& s) {
    auto t0 = std::chrono::steady_clock::now();
    BakeResult res;
    res.input = input;
    res.output = output;
    check_not_input(input, output);
    if (!same_wavelengths(s.basis.lambda, s.grid.lambda))
        throw Error("basis " + s.basis.name + " is not on the output grid " + s.grid.describe());

    auto src = ImageSource::open(input, s.max_pixels);
    const SourceInfo& info = src->info();
    if (info.miplevels > 1)
        res.notes.push_back("input has " + std::to_string(info.miplevels) + " MIP levels: the first was used");
    if (info.subimages > 1)
        res.notes.push_back("input has " + std::to_string(info.subimages) + " subimages: the first was used");
    if (info.channels > 4)
        res.notes.push_back("input has " + std::to_string(info.channels) + " channels: only RGB(A) were used");

    ColourRequest req{s.data_dir, s.config, s.colorspace, input, info.colorspace_hint};
    Linearizer lin = Linearizer::make(req);
    res.colorspace = lin.input_space();
    res.colorspace_how = lin.how_chosen();

    const bool has_alpha = info.alpha != AlphaKind::None;
    SpectralExrLayout layout;
    layout.x = info.x;
    layout.y = info.y;
    layout.width = info.width;
    layout.height = info.height;
    layout.full_x = info.full_x;
    layout.full_y = info.full_y;
    layout.full_width = info.full_width;
    layout.full_height = info.full_height;
    layout.lambda = s.grid.lambda;
    layout.type = s.type;
    layout.alpha = has_alpha;
    // Half holds every 8-bit alpha exactly enough to re-encode it; 16-bit and float alphas need float.
    layout.alpha_type = (s.type == SampleType::Half && (info.bits <= 8 || (info.is_float && info.bits == 16)))
                            ? SampleType::Half
                            : SampleType::Float;
    layout.preview = s.preview;
    layout.compression = s.compression;
    layout.attributes = {
        {"spectex:version", SPECTEX_VERSION},
        {"spectex:commandLine", s.command_line},
        {"spectex:source", input},
        {"spectex:basis", s.basis.name},
        {"spectex:basisSource", s.basis_source},
        {"spectex:basisChecksum", s.basis.checksum()},
        {"spectex:wavelengths", s.grid.describe()},
        {"spectex:wavelengthList", join_lambda(s.grid.lambda)},
        {"spectex:observer", s.observer},
        {"spectex:illuminant", s.illuminant},
        {"spectex:inputColorSpace", lin.input_space()},
        {"spectex:alpha", has_alpha ? (s.alpha == AlphaMode::Associated ? "associated" : "unassociated") : "none"},
        {"spectex:outOfRange", to_string(s.range)},
        {"spectex:nan", to_string(s.nan)},
        {"spectex:settingsHash", s.settings_hash},
    };
    layout.threads = s.threads;

    AtomicFile out(output);
    SpectralExrWriter writer(out, layout);

    const ExpansionMatrix m = ExpansionMatrix::from_basis(s.basis);
    const size_t w = static_cast<size_t>(info.width);
    const size_t es = s.type == SampleType::Half ? 2 : 4;
    const int chunk = s.compression.lines_per_chunk;
    size_t row_bytes = w * static_cast<size_t>(m.bins) * es;
    int strip = std::max(1, static_cast<int>(kStripBudget / std::max<size_t>(row_bytes, 1)) / chunk) * chunk;
    strip = std::min(strip, info.height);

    const size_t cap = w * static_cast<size_t>(strip);
    std::vector<float> rgba(cap * 4), r(cap), g(cap), b(cap), a(has_alpha ? cap : 0);
    std::vector<uint16_t> half_planes(s.type == SampleType::Half ? cap * static_cast<size_t>(m.bins) : 0);
    std::vector<float> float_planes(s.type == SampleType::Float ? cap * static_cast<size_t>(m.bins) : 0);
    const bool straighten = info.alpha == AlphaKind::Associated;
    const bool premultiply = has_alpha && s.alpha == AlphaMode::Associated;

    for (int y0 = 0; y0 < info.height; y0 += strip) {
        const int y1 = std::min(info.height, y0 + strip);
        const size_t n = w * static_cast<size_t>(y1 - y0);
        src->read_rgba(y0, y1, rgba.data());
        if (straighten) {
            for (size_t i = 0; i < n; ++i) {
                float al = rgba[4 * i + 3];
                if (al > 0 && al != 1)
                    for (int c = 0; c < 3; ++c) rgba[4 * i + c] /= al;
            }
        }
        lin.apply_rgba(rgba.data(), static_cast<long>(n));
        for (size_t i = 0; i < n; ++i) {
            float* p = &rgba[4 * i];
            bool bad = false, out_of_range = false;
            for (int c = 0; c < 4; ++c) {
                if (!std::isfinite(p[c])) {
                    if (s.nan == NanPolicy::Error)
                        throw Error(input + ": non-finite value at pixel (" + std::to_string(i % w) + ", " +
                                    std::to_string(y0 + static_cast<int>(i / w)) + ") (--nan error)");
                    p[c] = 0.0f;
                    bad = true;
                }
            }
            for (int c = 0; c < 3; ++c) {
                if (p[c] < 0.0f || p[c] > 1.0f) {
                    if (s.range == RangePolicy::Error)
                        throw Error(input + ": linear value " + std::to_string(p[c]) + " outside [0, 1] at pixel (" +
                                    std::to_string(i % w) + ", " + std::to_string(y0 + static_cast<int>(i / w)) +
                                    ") (--out-of-range error)");
                    if (s.range == RangePolicy::Clamp) {
                        p[c] = std::min(1.0f, std::max(0.0f, p[c]));
                        out_of_range = true;
                    }
                }
            }
            res.replaced_pixels += bad;
            res.clamped_pixels += out_of_range;
            float al = p[3];
            float k = premultiply ? al : 1.0f;
            r[i] = p[0] * k;
            g[i] = p[1] * k;
            b[i] = p[2] * k;
            if (has_alpha) a[i] = al;
        }
        const void* planes;
        if (s.type == SampleType::Half) {
            expand_to_half(m, r.data(), g.data(), b.data(), n, half_planes.data(), n);
            planes = half_planes.data();
        } else {
            expand_to_float(m, r.data(), g.data(), b.data(), n, float_planes.data(), n);
            planes = float_planes.data();
        }
        writer.write_rows(y1 - y0, planes, n, a.data(), r.data(), g.data(), b.data());
    }
    writer.finish();
    struct stat st;
    if (::fstat(out.fd(), &st) == 0) res.bytes = static_cast<uint64_t>(st.st_size);
    out.commit();
    res.pixels = static_cast<uint64_t>(info.width) * static_cast<uint64_t>(info.height);
    res.bins = m.bins;
    res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return res;
}

}  // namespace spectex
