// The floor: what writing a spectral scanline OpenEXR costs with nothing else to do. A W×H, N-bin
// file in the Fichet layout (channels T.<λ>nm, spectralLayoutVersion) is written with
// spectex's own writer (spectex::SpectralExrWriter on an AtomicFile: temporary file, fsync,
// rename) from pixels expanded once, before the clock starts: a smooth synthetic pattern is
// expanded into one strip buffer, which is handed to the writer for every strip.
//
// Configured as spectex bake configures it (src/pipeline/bake.cpp): the same writer choice
// (--writer auto: the core-API writer with libdeflate for none/zips/zip, OpenEXR's C++
// writer otherwise; --writer imf forces the C++ one), the same ZIP level unless --zip-level, the
// same strip size (spectex::strip_rows: about 32 MB of samples, whole chunks for the C++ writer), T
// compression threads (Imf::setGlobalThreadCount(T) for the C++ writer).
//
// --method basis|lattice|jakob-hanika (with --lattice-size N) expands with that method, through the
// same SpectralMethod and colour-aware half rounding as spectex bake, so that each method's bake is
// compared with the floor of writing its own spectra (ZIP's cost depends on them). Without it the
// fitted basis with plain rounding (the floor's original figures).
//
// --source IMAGE replaces the synthetic pattern by the first strip of that image (read and
// linearised as spectex does, clamped to [0, 1]), so that the encoder sees the same kind of content
// as the bake it is compared with (ZIP's cost depends on it); the size is then the image's unless
// --width/--height are given. Still expanded once, before the clock.
//
// Prints one JSON line: wall seconds and CPU seconds (user + system, whole process) of the write
// (from opening the file to the rename), output bytes, peak RSS.
//
//   bench_exr_floor --width 4096 --height 4096 --bins 81 --type half --compression zip --threads 2
//   --out /tmp/floor.exr
#include <ImfThreading.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "io/atomic_file.h"
#include "io/image_source.h"
#include "io/linearizer.h"
#include "io/spectral_exr_writer.h"
#include "pipeline/bake.h"
#include "pipeline/method_table.h"
#include "spectral/basis.h"
#include "spectral/basis_fit.h"
#include "spectral/expand.h"
#include "spectral/spectral_method.h"
#include "spectral/wavelength_grid.h"

using namespace spectex;

namespace {

double cpu_seconds() {
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_utime.tv_sec + ru.ru_utime.tv_usec * 1e-6 + ru.ru_stime.tv_sec +
           ru.ru_stime.tv_usec * 1e-6;
}

[[noreturn]] void usage(const char* msg) {
    std::fprintf(
        stderr,
        "%s\nusage: bench_exr_floor [--width W] [--height H] [--bins N | --wavelengths S:E:STEP]\n"
        "                       [--type half|float] [--compression NAME] [--threads T]\n"
        "                       [--zip-level L] [--writer auto|core|imf] [--source IMAGE] "
        "[--whole]\n"
        "                       [--method basis|lattice|jakob-hanika] [--lattice-size N]\n"
        "                       [--out FILE.exr] [--keep]\n"
        "defaults: 4096 x 4096, 81 bins (380:780:5), half, zip, T = cores, "
        "/tmp/bench_exr_floor.exr\n",
        msg);
    std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
    int width = 0, height = 0, bins = 81,
        threads = static_cast<int>(std::thread::hardware_concurrency());
    int zip_level = -1;
    std::string type = "half", compression = "zip", out = "/tmp/bench_exr_floor.exr", wavelengths,
                source;
    std::string writer = "auto";  // as spectex bake: core for none/zips/zip, else imf
    // --whole (with --source): expand the whole image before the clock starts, so the writer
    // compresses exactly the pixels spectex writes (ZIP's time depends on content).
    bool whole = false;
    bool keep = false;
    std::string method_name;  // empty: the fitted basis, plain rounding
    int lattice_size = 9;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto val = [&]() -> std::string {
            if (i + 1 >= argc) usage(("missing value for " + a).c_str());
            return argv[++i];
        };
        if (a == "--width")
            width = std::stoi(val());
        else if (a == "--height")
            height = std::stoi(val());
        else if (a == "--bins")
            bins = std::stoi(val());
        else if (a == "--wavelengths")
            wavelengths = val();
        else if (a == "--type")
            type = val();
        else if (a == "--compression")
            compression = val();
        else if (a == "--threads")
            threads = std::stoi(val());
        else if (a == "--zip-level")
            zip_level = std::stoi(val());
        else if (a == "--writer")
            writer = val();
        else if (a == "--out")
            out = val();
        else if (a == "--keep")
            keep = true;
        else if (a == "--source")
            source = val();
        else if (a == "--whole")
            whole = true;
        else if (a == "--method")
            method_name = val();
        else if (a == "--lattice-size")
            lattice_size = std::stoi(val());
        else if (a == "-h" || a == "--help")
            usage("bench_exr_floor: the OpenEXR-only floor of spectex bake");
        else
            usage(("unknown option " + a).c_str());
    }
    std::unique_ptr<ImageSource> src;
    try {
        if (!source.empty()) {
            src = ImageSource::open(source, 1ull << 32);
            if (width <= 0) width = src->info().width;
            if (height <= 0) height = src->info().height;
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_exr_floor: %s\n", e.what());
        return 1;
    }
    if (width <= 0) width = 4096;
    if (height <= 0) height = 4096;
    if (width < 1 || height < 1 || threads < 1 || (type != "half" && type != "float"))
        usage("bad width, height, threads or type");
    try {
        const WavelengthGrid grid =
            !wavelengths.empty()
                ? WavelengthGrid::parse(wavelengths)
                : (bins < 3 ? throw std::runtime_error("--bins must be >= 3")
                            : WavelengthGrid::uniform_grid(380, 780, 400.0 / (bins - 1)));
        bins = static_cast<int>(grid.size());
        const ExrCompression comp = ExrCompression::parse(compression);
        const bool half = type == "half";
        const size_t es = half ? 2 : 4;

        // Strip size exactly as bake.cpp computes it.
        const size_t w = static_cast<size_t>(width);
        const size_t row_bytes = w * static_cast<size_t>(bins) * es;
        const int chunk = comp.lines_per_chunk;
        SpectralExrLayout probe;
        probe.compression = comp;
        probe.writer = writer;
        const int strip =
            strip_rows(row_bytes, chunk, !SpectralExrWriter::uses_core(probe), height);

        // A smooth synthetic pattern, expanded once with a basis fitted on the grid (realistic
        // spectra, so that compression sees realistic data).
        Basis basis;
        try {
            Observer o = load_observer(SPECTEX_TEST_DATA_DIR, "cie1931-2");
            Spectrum d65 = load_illuminant(SPECTEX_TEST_DATA_DIR, "D65");
            basis = fit_basis({Colorimetry::make(o, d65, grid, primaries_by_name("srgb")),
                               FitObjective::Smooth, true})
                        .basis;
        } catch (const std::exception&) {
            basis.lambda = grid.lambda;  // no fit on this grid: a plain smooth ramp basis
            for (size_t k = 0; k < grid.size(); ++k) {
                double t = static_cast<double>(k) / std::max<size_t>(1, grid.size() - 1);
                basis.r.push_back(t * t);
                basis.b.push_back((1 - t) * (1 - t));
                basis.g.push_back(1 - t * t - (1 - t) * (1 - t));
            }
        }
        const ExpansionMatrix m = ExpansionMatrix::from_basis(basis);
        // With --method: the method and the colour-aware rounding weights, as bake.cpp makes them.
        std::shared_ptr<const SpectralMethod> method;
        std::vector<float> rgb_weight;
        if (!method_name.empty()) {
            FitSpec fit;
            fit.data_dir = SPECTEX_TEST_DATA_DIR;
            fit.grid = grid;
            if (method_name == "basis") {
                method =
                    std::make_shared<BasisMethod>(fit_basis_for(fit).basis, "fitted by spectex");
            } else {
                MethodSpec ms;
                ms.kind = find_method(method_name)->kind;
                ms.fit = fit;
                ms.lattice_size = lattice_size;
                method = make_method(ms).method;
            }
            const Colorimetry c = Colorimetry::make(load_observer(fit.data_dir, fit.observer),
                                                    load_illuminant(fit.data_dir, fit.illuminant),
                                                    grid, primaries_by_name("srgb"));
            const Eigen::Matrix3Xd R = c.rgb_weights();
            for (Eigen::Index k = 0; k < R.cols(); ++k)
                for (int ch = 0; ch < 3; ++ch) rgb_weight.push_back(static_cast<float>(R(ch, k)));
        }
        auto expand_half = [&](const float* rr, const float* gg, const float* bb, size_t count,
                               uint16_t* o) {
            if (method)
                method->expand_half(rr, gg, bb, count, o, count, &rgb_weight);
            else
                expand_to_half(m, rr, gg, bb, count, o, count);
        };
        auto expand_float = [&](const float* rr, const float* gg, const float* bb, size_t count,
                                float* o) {
            if (method)
                method->expand_float(rr, gg, bb, count, o, count);
            else
                expand_to_float(m, rr, gg, bb, count, o, count);
        };
        const size_t n = w * static_cast<size_t>(strip);
        std::vector<float> r(n), g(n), b(n);
        for (int y = 0; y < strip; ++y)
            for (size_t x = 0; x < w; ++x) {
                const double u = static_cast<double>(x) / static_cast<double>(w),
                             v = static_cast<double>(y) / height;
                const size_t i = static_cast<size_t>(y) * w + x;
                r[i] = static_cast<float>(0.5 + 0.45 * std::sin(6.2831853 * (u * 3 + v)));
                g[i] = static_cast<float>(0.5 + 0.45 * std::sin(6.2831853 * (u * 2 - v * 5) + 1.0));
                b[i] = static_cast<float>(0.5 + 0.45 * std::cos(6.2831853 * (u + v * 2) + 2.0));
            }
        if (src) {  // the first strip of the image, tiled over the strip buffer
            const int sw = src->info().width, sh = std::min(src->info().height, strip);
            std::vector<float> rgba(static_cast<size_t>(sw) * sh * 4);
            src->read_rgba(0, sh, rgba.data());
            Linearizer lin = Linearizer::make(
                ColourRequest{SPECTEX_TEST_DATA_DIR, "", "", source, src->info().colour});
            lin.apply_rgba(rgba.data(), static_cast<long>(rgba.size() / 4));
            auto c01 = [](float v) {
                return std::isfinite(v) ? std::min(1.0f, std::max(0.0f, v)) : 0.0f;
            };
            for (int y = 0; y < strip; ++y)
                for (size_t x = 0; x < w; ++x) {
                    const float* p =
                        &rgba[4 * (static_cast<size_t>(y % sh) * sw + x % static_cast<size_t>(sw))];
                    const size_t i = static_cast<size_t>(y) * w + x;
                    r[i] = c01(p[0]);
                    g[i] = c01(p[1]);
                    b[i] = c01(p[2]);
                }
        }
        std::vector<uint16_t> hbuf;
        std::vector<float> fbuf;
        const char* planes;
        if (half) {
            hbuf.resize(n * static_cast<size_t>(bins));
            expand_half(r.data(), g.data(), b.data(), n, hbuf.data());
            planes = reinterpret_cast<const char*>(hbuf.data());
        } else {
            fbuf.resize(n * static_cast<size_t>(bins));
            expand_float(r.data(), g.data(), b.data(), n, fbuf.data());
            planes = reinterpret_cast<const char*>(fbuf.data());
        }
        std::vector<std::string> names;
        for (double l : grid.lambda) names.push_back(reflective_channel_name(l));
        std::vector<std::vector<char>> whole_strips;  // bin-major planes per strip
        if (whole && src) {
            if (src->info().width != width || src->info().height != height)
                throw std::runtime_error(
                    "--whole needs --width/--height equal to the source's size");
            Linearizer lin = Linearizer::make(
                ColourRequest{SPECTEX_TEST_DATA_DIR, "", "", source, src->info().colour});
            std::vector<float> rgba;
            for (int y0 = 0; y0 < height; y0 += strip) {
                const int rows = std::min(strip, height - y0);
                const size_t ns = w * static_cast<size_t>(rows);
                rgba.resize(ns * 4);
                src->read_rgba(y0, y0 + rows, rgba.data());
                lin.apply_rgba(rgba.data(), static_cast<long>(ns));
                auto c01 = [](float v) {
                    return std::isfinite(v) ? std::min(1.0f, std::max(0.0f, v)) : 0.0f;
                };
                std::vector<float> rr(ns), gg(ns), bb(ns);
                for (size_t i = 0; i < ns; ++i)
                    rr[i] = c01(rgba[4 * i]), gg[i] = c01(rgba[4 * i + 1]),
                    bb[i] = c01(rgba[4 * i + 2]);
                whole_strips.emplace_back(ns * static_cast<size_t>(bins) * es);
                if (half)
                    expand_half(rr.data(), gg.data(), bb.data(), ns,
                                reinterpret_cast<uint16_t*>(whole_strips.back().data()));
                else
                    expand_float(rr.data(), gg.data(), bb.data(), ns,
                                 reinterpret_cast<float*>(whole_strips.back().data()));
            }
        }

        Imf::setGlobalThreadCount(threads);
        const double c0 = cpu_seconds();
        const auto t0 = std::chrono::steady_clock::now();
        uint64_t bytes = 0;
        std::string used;
        {
            AtomicFile file(out);
            SpectralExrLayout layout;
            layout.width = layout.full_width = width;
            layout.height = layout.full_height = height;
            layout.lambda = grid.lambda;
            layout.type = half ? SampleType::Half : SampleType::Float;
            layout.compression = comp;
            layout.threads = threads;
            layout.writer = writer;
            if (zip_level >= 0) layout.zip_level = zip_level;
            SpectralExrWriter exr(file, layout);
            used = exr.writer_name();
            for (int y0 = 0; y0 < height; y0 += strip) {
                const int rows = std::min(strip, height - y0);
                const bool ws = !whole_strips.empty();
                const char* sp = ws ? whole_strips[static_cast<size_t>(y0 / strip)].data() : planes;
                const size_t pn = ws ? w * static_cast<size_t>(rows) : n;
                exr.write_rows(rows, sp, pn, nullptr, nullptr, nullptr, nullptr);
            }
            exr.finish();
            struct stat st;
            if (::fstat(file.fd(), &st) == 0) bytes = static_cast<uint64_t>(st.st_size);
            file.commit();
        }
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const double cpu = cpu_seconds() - c0;
        if (!keep) ::unlink(out.c_str());
        rusage ru{};
        getrusage(RUSAGE_SELF, &ru);
        std::printf(
            "{\"width\": %d, \"height\": %d, \"bins\": %d, \"type\": \"%s\", \"compression\": "
            "\"%s\", "
            "\"writer\": \"%s\", \"zip_level\": %d, \"threads\": %d, \"strip_rows\": %d, "
            "\"lines_per_chunk\": %d, "
            "\"method\": \"%s\", \"pattern\": \"%s\", \"wall_s\": %.4f, \"cpu_s\": %.4f, "
            "\"bytes\": %llu, \"megapixels_per_s\": %.3f, \"peak_rss_mb\": %.1f}\n",
            width, height, bins, type.c_str(), comp.name.c_str(), used.c_str(),
            zip_level >= 0 ? zip_level : SpectralExrLayout().zip_level, threads, strip, chunk,
            method ? method->name().c_str() : "basis (plain rounding)",
            whole_strips.size() ? "source, whole image"
            : src               ? "source first strip"
                                : "synthetic smooth",
            wall, cpu, static_cast<unsigned long long>(bytes),
            static_cast<double>(width) * height / 1e6 / wall, ru.ru_maxrss / 1024.0);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_exr_floor: %s\n", e.what());
        return 1;
    }
    return 0;
}
