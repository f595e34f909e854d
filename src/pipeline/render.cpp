#include "pipeline/render.h"

#include <algorithm>
#include <memory>

#include "base/error.h"
#include "base/task_pool.h"
#include "io/atomic_file.h"
#include "io/image_library.h"
#include "io/spectral_reader.h"
#include "pipeline/bitmap_font.h"
#include "pipeline/look.h"
#include "spectral/adaptation.h"

namespace spectex {

namespace {

constexpr uint8_t kBackground[4] = {40, 40, 40, 255};
constexpr uint8_t kInk[4] = {235, 235, 235, 255};

// Integrates pixels [begin, end) of a band under one light into 8-bit codes of `out` (nch
// channels, panel_x0 the panel's first column in the output row).
void integrate(const float* planes, size_t plane, const float* alpha, int bins, size_t w,
               const Eigen::Matrix3Xd& wrgb, bool associated, bool has_alpha, size_t begin,
               size_t end, uint8_t* out, size_t out_stride, size_t panel_x0, int nch) {
    constexpr size_t kBlock = 256;
    double acc[3][kBlock];
    const double* wt = wrgb.data();  // column-major: 3 per bin
    for (size_t i0 = begin; i0 < end; i0 += kBlock) {
        const size_t m = std::min(kBlock, end - i0);
        for (auto& a : acc) std::fill(a, a + m, 0.0);
        for (int k = 0; k < bins; ++k) {
            const float* p = planes + static_cast<size_t>(k) * plane + i0;
            const double w0 = wt[3 * k], w1 = wt[3 * k + 1], w2 = wt[3 * k + 2];
            for (size_t j = 0; j < m; ++j) {
                const double d = p[j];
                acc[0][j] += w0 * d;
                acc[1][j] += w1 * d;
                acc[2][j] += w2 * d;
            }
        }
        for (size_t j = 0; j < m; ++j) {
            const size_t idx = i0 + j, row = idx / w, col = idx % w;
            uint8_t* q = out + row * out_stride + (panel_x0 + col) * static_cast<size_t>(nch);
            const double a = has_alpha ? static_cast<double>(alpha[idx]) : 1.0;
            if (associated && !(a > 0)) {
                for (int c = 0; c < nch; ++c) q[c] = 0;
                continue;
            }
            const double div = associated ? a : 1.0;
            for (int c = 0; c < 3; ++c) q[c] = static_cast<uint8_t>(srgb8(acc[c][j] / div));
            if (nch == 4)
                q[3] = static_cast<uint8_t>(std::lround(std::min(1.0, std::max(0.0, a)) * 255.0));
        }
    }
}

}  // namespace

RenderReport render_file(const std::string& exr_path, const std::string& png_path,
                         const RenderSettings& s) {
    SpectralReader reader(exr_path);
    const SpectralExrInfo& info = reader.info();
    const uint64_t pixels = static_cast<uint64_t>(info.width) * static_cast<uint64_t>(info.height);
    if (pixels > s.max_pixels)
        throw Error(exr_path + ": " + std::to_string(info.width) + "x" +
                    std::to_string(info.height) + " = " + std::to_string(pixels) +
                    " pixels exceed the limit of " + std::to_string(s.max_pixels) +
                    " (--max-pixels)");
    if (info.width <= 0 || info.height <= 0) throw Error(exr_path + ": empty data window");
    Viewer v;
    try {
        v = Viewer::make(s.data_dir, s.observer, reader.wavelengths(), s.illuminants);
    } catch (const Error& e) {
        throw Error(exr_path + ": " + e.what());
    }

    RenderReport r;
    r.file = exr_path;
    r.output = png_path;
    const int n = static_cast<int>(v.lights.size());
    const int w = info.width, h = info.height;
    r.panel_width = w;
    r.panel_height = h;
    const int scale = std::max(1, std::min(4, w / 128));
    r.gap = n > 1 ? 4 * scale : 0;
    r.label_height = n > 1 ? (kGlyphHeight + 4) * scale : 0;
    const int64_t out_w = static_cast<int64_t>(w) * n + static_cast<int64_t>(r.gap) * (n - 1);
    if (out_w > 1000000000)
        throw Error(exr_path + ": a sheet of " + std::to_string(n) + " panels is too wide");
    r.width = static_cast<int>(out_w);
    r.height = h + r.label_height;
    // The sheet is an image too: --max-pixels bounds it as it bounds the file (its rows are
    // written a band at a time, but a sheet of 1,000 panels of a 512^2 file is 278 megapixels
    // that nobody asked for by that name). Refused before any pixel is read.
    const uint64_t sheet = static_cast<uint64_t>(out_w) * static_cast<uint64_t>(r.height);
    if (n > 1 && sheet > s.max_pixels)
        throw LimitError("--max-pixels: a sheet of " + std::to_string(n) + " panels of " +
                         std::to_string(w) + "x" + std::to_string(h) + " is " +
                         std::to_string(out_w) + "x" + std::to_string(r.height) + " = " +
                         std::to_string(sheet) + " pixels, over the limit of " +
                         std::to_string(s.max_pixels) +
                         " (--max-pixels); give fewer lights or a larger --max-pixels");
    r.channels = info.alpha ? 4 : 3;
    for (const auto& l : v.lights) r.labels.push_back(l.label);
    const int nch = r.channels;
    const size_t out_stride = static_cast<size_t>(r.width) * static_cast<size_t>(nch);
    const bool associated = reader.alpha() == AlphaKind::Associated;

    AtomicFile file(png_path);
    std::string description = "spectex render of " + exr_path + " under";
    for (const auto& l : v.lights) description += " " + l.name;
    description += s.adapt ? " (Bradford-adapted to D65)" : " (not adapted)";
    std::unique_ptr<PngWriter> out =
        image_library().png_writer(file.temp_path(), png_path, r.width, r.height, nch,
                                   {{"ImageDescription", description}, {"Software", "spectex"}});
    auto write_rows = [&](int y0, int rows, const uint8_t* data) {
        out->write_rows(y0, rows, data);
    };

    // Label strip.
    if (r.label_height > 0) {
        std::vector<uint8_t> strip(out_stride * static_cast<size_t>(r.label_height));
        for (size_t i = 0; i < strip.size(); i += static_cast<size_t>(nch))
            std::copy(kBackground, kBackground + nch,
                      strip.begin() + static_cast<std::ptrdiff_t>(i));
        for (int p = 0; p < n; ++p) {
            const int x0 = p * (w + r.gap);
            std::string label = v.lights[static_cast<size_t>(p)].label;
            const int tw = text_width(label, scale);
            const int x = x0 + std::max(scale, (w - tw) / 2);
            draw_text(strip.data(), r.width, r.label_height, nch, out_stride, x, 2 * scale, label,
                      scale, kInk, x0 + w);
        }
        write_rows(0, r.label_height, strip.data());
    }

    const int band = reader.band_rows(s.band_bytes);
    const size_t plane = static_cast<size_t>(w) * static_cast<size_t>(band);
    const int bins = reader.bins();
    std::vector<float> planes(plane * static_cast<size_t>(bins)), alpha(plane, 1.0f);
    std::vector<uint8_t> rows(out_stride * static_cast<size_t>(band));
    for (size_t i = 0; i < rows.size(); i += static_cast<size_t>(nch))
        std::copy(kBackground, kBackground + nch, rows.begin() + static_cast<std::ptrdiff_t>(i));
    const int nthreads = s.threads > 0 ? s.threads : hardware_threads();
    for (int y0 = 0; y0 < h; y0 += band) {
        const int nrows = std::min(band, h - y0);
        reader.read_rows(y0, nrows, planes.data(), plane, alpha.data());
        const size_t count = static_cast<size_t>(w) * static_cast<size_t>(nrows);
        for (int p = 0; p < n; ++p) {
            const LightView& l = v.lights[static_cast<size_t>(p)];
            const Eigen::Matrix3Xd& wrgb = s.adapt ? l.rgb_adapted : l.rgb_unadapted;
            const size_t x0 = static_cast<size_t>(p) * static_cast<size_t>(w + r.gap);
            const size_t per =
                (count + static_cast<size_t>(nthreads) - 1) / static_cast<size_t>(nthreads);
            TaskPool::shared().parallel_for(static_cast<size_t>(nthreads), nthreads, [&](size_t t) {
                const size_t b = std::min(count, per * t), e = std::min(count, b + per);
                if (b < e)
                    integrate(planes.data(), plane, alpha.data(), bins, static_cast<size_t>(w),
                              wrgb, associated, info.alpha, b, e, rows.data(), out_stride, x0, nch);
            });
        }
        write_rows(r.label_height + y0, nrows, rows.data());
    }
    out->close();
    out.reset();
    file.commit();
    return r;
}

}  // namespace spectex
