// The spectral EXR writer, both back ends (openexr_core + libdeflate, and OpenEXR's C++ library),
// read back with OpenEXR's C++ reader: every sample's bits, for every compression the core writer
// takes, odd sizes and origins, strips that do not line up with chunks, incompressible blocks.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <ImfTiledInputFile.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "base/half.h"
#include "io/atomic_file.h"
#include "io/exr_core_writer.h"
#include "io/spectral_exr_writer.h"
#include "spectral/wavelength_grid.h"

using namespace spectex;

namespace {

struct Case {
    std::string compression;
    SampleType type;
    bool noise;  // random bits: deflate cannot shrink them, so chunks are stored raw
};

struct Data {
    int w, h, bins;
    std::vector<uint16_t> half;  // bins planes of w*h
    std::vector<float> flt;
    std::vector<float> alpha, r, g, b;
};

Data make_data(int w, int h, int bins, bool noise, unsigned seed) {
    Data d{w, h, bins, {}, {}, {}, {}, {}, {}};
    const size_t n = static_cast<size_t>(w) * h;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    d.half.resize(n * bins);
    d.flt.resize(n * bins);
    for (int k = 0; k < bins; ++k)
        for (size_t i = 0; i < n; ++i) {
            // Smooth spectra (compressible) or random finite bits (not).
            const float v =
                noise ? u(rng) : 0.5f + 0.4f * std::sin(0.05f * k + 0.001f * static_cast<float>(i));
            // Noise: every 16-bit pattern (NaNs too: the test compares bits, never values).
            uint16_t hb = noise ? static_cast<uint16_t>(rng() & 0xffff) : float_to_half(v);
            d.half[k * n + i] = hb;
            d.flt[k * n + i] = noise ? u(rng) * 3.0f - 1.0f : v;
        }
    for (size_t i = 0; i < n; ++i) {
        d.alpha.push_back(u(rng));
        d.r.push_back(u(rng));
        d.g.push_back(u(rng));
        d.b.push_back(u(rng));
    }
    return d;
}

std::string temp_name(const std::string& tag) {
    char tmpl[] = "/tmp/spectex-exrw-XXXXXX";
    const int fd = mkstemp(tmpl);
    close(fd);
    unlink(tmpl);
    return std::string(tmpl) + "-" + tag + ".exr";
}

SpectralExrLayout layout_for(const Data& d, const Case& c, const std::string& writer, int threads) {
    SpectralExrLayout L;
    L.x = -3;
    L.y = 5;
    L.width = d.w;
    L.height = d.h;
    L.full_x = 0;
    L.full_y = 0;
    L.full_width = d.w + 10;
    L.full_height = d.h + 10;
    for (int k = 0; k < d.bins; ++k) L.lambda.push_back(380.0 + 5.0 * k);
    L.type = c.type;
    L.alpha = true;
    L.alpha_type = SampleType::Float;
    L.preview = true;
    L.compression = ExrCompression::parse(c.compression);
    L.attributes = {{"spectex:test", "yes"}};
    L.writer = writer;
    L.threads = threads;
    return L;
}

// Writes d in strips of the given row counts (cycled).
std::string write(const Data& d, const Case& c, const std::string& writer, int threads,
                  const std::vector<int>& strips, std::string* used = nullptr,
                  SpectralExrWriter::Timing* timing = nullptr) {
    const std::string path = temp_name(writer + "-" + c.compression);
    AtomicFile file(path);
    SpectralExrWriter wr(file, layout_for(d, c, writer, threads));
    if (used) *used = wr.writer_name();
    const size_t n = static_cast<size_t>(d.w) * d.h;
    const size_t es = c.type == SampleType::Half ? 2 : 4;
    int y = 0;
    for (size_t s = 0; y < d.h; ++s) {
        const int rows = std::min(strips[s % strips.size()], d.h - y);
        const size_t rows_n = static_cast<size_t>(d.w) * rows;
        // A strip holds its own bin planes, rows_n apart (as the bake's strips do).
        std::vector<char> planes(rows_n * d.bins * es);
        for (int k = 0; k < d.bins; ++k) {
            const char* src = c.type == SampleType::Half
                                  ? reinterpret_cast<const char*>(d.half.data() + k * n +
                                                                  static_cast<size_t>(y) * d.w)
                                  : reinterpret_cast<const char*>(d.flt.data() + k * n +
                                                                  static_cast<size_t>(y) * d.w);
            std::memcpy(planes.data() + k * rows_n * es, src, rows_n * es);
        }
        const size_t off = static_cast<size_t>(y) * d.w;
        wr.write_rows(rows, planes.data(), rows_n, d.alpha.data() + off, d.r.data() + off,
                      d.g.data() + off, d.b.data() + off);
        y += rows;
    }
    wr.finish();
    if (timing) *timing = wr.timing();
    file.commit();
    return path;
}

// Reads every channel's raw bits (half as uint16, float as uint32) with OpenEXR's C++ reader.
std::map<std::string, std::vector<uint32_t>> read_bits(const std::string& path,
                                                       Imf::Header* header = nullptr) {
    Imf::InputFile in(path.c_str());
    if (header) *header = in.header();
    const Imath::Box2i dw = in.header().dataWindow();
    const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    std::map<std::string, std::vector<uint32_t>> out;
    Imf::FrameBuffer fb;
    for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it) {
        auto& v = out[it.name()];
        v.assign(static_cast<size_t>(w) * h, 0);
        // 4-byte cells; a half lands in the low two bytes (little-endian host).
        char* base = reinterpret_cast<char*>(v.data()) -
                     (static_cast<ptrdiff_t>(dw.min.y) * w + dw.min.x) * 4;
        fb.insert(it.name(), Imf::Slice(it.channel().type, base, 4, 4 * static_cast<size_t>(w)));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    return out;
}

void expect_file_holds(const std::string& path, const Data& d, const Case& c) {
    Imf::Header header;
    auto bits = read_bits(path, &header);
    EXPECT_EQ(header.dataWindow().min.x, -3);
    EXPECT_EQ(header.dataWindow().min.y, 5);
    EXPECT_EQ(header.displayWindow().max.x, d.w + 9);
    EXPECT_EQ(header.compression(),
              static_cast<Imf::Compression>(ExrCompression::parse(c.compression).id));
    const auto* v = header.findTypedAttribute<Imf::StringAttribute>("spectralLayoutVersion");
    ASSERT_NE(v, nullptr);
    EXPECT_EQ(v->value(), "1.0");
    ASSERT_NE(header.findTypedAttribute<Imf::StringAttribute>("spectex:test"), nullptr);
    const size_t n = static_cast<size_t>(d.w) * d.h;
    ASSERT_EQ(bits.size(), static_cast<size_t>(d.bins) + 4);
    for (int k = 0; k < d.bins; ++k) {
        const auto& got = bits.at(reflective_channel_name(380.0 + 5.0 * k));
        size_t bad = 0;
        for (size_t i = 0; i < n; ++i) {
            uint32_t want;
            if (c.type == SampleType::Half)
                want = d.half[k * n + i];
            else
                std::memcpy(&want, &d.flt[k * n + i], 4);
            bad += got[i] != want;
        }
        EXPECT_EQ(bad, 0u) << "bin " << k;
    }
    for (size_t i = 0; i < n; ++i) {
        uint32_t a;
        std::memcpy(&a, &d.alpha[i], 4);
        ASSERT_EQ(bits.at("A")[i], a) << i;
        const uint32_t r = c.type == SampleType::Half ? float_to_half(d.r[i]) : [&] {
            uint32_t x;
            std::memcpy(&x, &d.r[i], 4);
            return x;
        }();
        ASSERT_EQ(bits.at("R")[i], r) << i;
    }
}

}  // namespace

TEST(ExrWriter, CoreAndImfWritersStoreTheSameSamples) {
    const std::vector<Case> cases = {
        {"zip", SampleType::Half, false},  {"zip", SampleType::Half, true},
        {"zip", SampleType::Float, false}, {"zips", SampleType::Half, false},
        {"zips", SampleType::Float, true}, {"none", SampleType::Half, false},
        {"none", SampleType::Float, true},
    };
    // 37 x 53: rows not a multiple of ZIP's 16; strips of 7, 1, 29 rows straddle chunks.
    for (const auto& c : cases) {
        SCOPED_TRACE(c.compression + (c.type == SampleType::Half ? " half" : " float") +
                     (c.noise ? " noise" : ""));
        const Data d = make_data(37, 53, 9, c.noise, 11);
        std::string used;
        SpectralExrWriter::Timing t;
        const std::string core = write(d, c, "core", 2, {7, 1, 29}, &used, &t);
        EXPECT_EQ(used, "core");
        // Random half bits do not deflate: those chunks must take the stored-raw path.
        if (c.noise && c.type == SampleType::Half && c.compression != "none")
            EXPECT_GT(t.raw_chunks, 0);
        if (!c.noise) EXPECT_EQ(t.raw_chunks, 0);
        const std::string imf = write(d, c, "imf", 2, {16}, &used);
        EXPECT_EQ(used, "imf");
        expect_file_holds(core, d, c);
        expect_file_holds(imf, d, c);
        unlink(core.c_str());
        unlink(imf.c_str());
    }
}

TEST(ExrWriter, CoreWriterIsDeterministicAcrossThreadCounts) {
    const Case c{"zip", SampleType::Half, false};
    const Data d = make_data(64, 70, 12, false, 3);
    const std::string a = write(d, c, "core", 1, {16});
    const std::string b = write(d, c, "core", 3, {5, 11});
    auto slurp = [](const std::string& p) {
        std::ifstream f(p, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(f), {});
    };
    EXPECT_EQ(slurp(a), slurp(b));
    unlink(a.c_str());
    unlink(b.c_str());
}

TEST(ExrWriter, CoreWriterCapsChunkBuffersWhateverTheBinCount) {
    // 401 bins: one ZIP chunk of 16 rows x 256 px is 3.3 MB. Whatever the image height, the
    // writer holds threads + 1 chunk buffers, no more (the C++ writer holds 2 x threads, each
    // with its own compression buffers).
    const Case c{"zip", SampleType::Half, false};
    const Data d = make_data(256, 160, 401, false, 5);
    SpectralExrWriter::Timing t;
    const std::string p = write(d, c, "core", 2, {3}, nullptr, &t);
    EXPECT_LE(t.buffers, 3);
    EXPECT_GE(t.buffers, 1);
    EXPECT_EQ(t.chunk_bytes,
              16u * 256u * (401u * 2u + 3u * 2u + 4u));  // 401 + R,G,B half + A float
    expect_file_holds(p, d, c);
    unlink(p.c_str());
}

TEST(ExrWriter, OtherCompressionsUseTheCppWriter) {
    const Data d = make_data(16, 16, 3, false, 1);
    std::string used;
    const std::string p = write(d, Case{"piz", SampleType::Half, false}, "auto", 1, {16}, &used);
    EXPECT_EQ(used, "imf");
    unlink(p.c_str());
    EXPECT_FALSE(ExrCoreWriter::supports("piz"));
    EXPECT_TRUE(ExrCoreWriter::supports("zip"));
}

namespace {

// Writes a tiled (optionally MIP-mapped) file: level l holds make_data(level size, seed l), given
// in tile rows; returns the path and each level's data.
std::string write_tiled(const Case& c, const std::string& writer, int w, int h, int tw, int th,
                        bool mip, std::vector<Data>& levels, std::string* used) {
    const std::string path = temp_name("tiled-" + writer + "-" + c.compression);
    AtomicFile file(path);
    Data shape = make_data(w, h, 5, false, 0);
    SpectralExrLayout L = layout_for(shape, c, writer, 2);
    L.tile_width = tw;
    L.tile_height = th;
    L.mipmap = mip;
    SpectralExrWriter wr(file, L);
    *used = wr.writer_name();
    levels.clear();
    const size_t es = c.type == SampleType::Half ? 2 : 4;
    for (int l = 0; l < wr.levels(); ++l) {
        const int lw = wr.level_width(l), lh = wr.level_height(l);
        levels.push_back(make_data(lw, lh, 5, c.noise, 100 + static_cast<unsigned>(l)));
        const Data& d = levels.back();
        const size_t n = static_cast<size_t>(lw) * lh;
        for (int y0 = 0; y0 < lh; y0 += th) {
            const int rows = std::min(th, lh - y0);
            const size_t rn = static_cast<size_t>(lw) * rows, off = static_cast<size_t>(y0) * lw;
            std::vector<char> planes(rn * d.bins * es);
            for (int k = 0; k < d.bins; ++k) {
                const char* src = c.type == SampleType::Half
                                      ? reinterpret_cast<const char*>(d.half.data() + k * n + off)
                                      : reinterpret_cast<const char*>(d.flt.data() + k * n + off);
                std::memcpy(planes.data() + k * rn * es, src, rn * es);
            }
            wr.write_level_rows(l, y0, rows, planes.data(), rn, d.alpha.data() + off,
                                d.r.data() + off, d.g.data() + off, d.b.data() + off);
        }
    }
    wr.finish();
    file.commit();
    return path;
}

// Every level's samples, as raw bits, read with OpenEXR's C++ tiled reader.
std::vector<std::map<std::string, std::vector<uint32_t>>> read_tiled_bits(const std::string& path,
                                                                          Imf::Header* hdr) {
    Imf::TiledInputFile in(path.c_str());
    *hdr = in.header();
    std::vector<std::map<std::string, std::vector<uint32_t>>> out;
    const Imath::Box2i dw = in.header().dataWindow();
    for (int l = 0; l < in.numLevels(); ++l) {
        const int w = in.levelWidth(l), h = in.levelHeight(l);
        auto& m = out.emplace_back();
        Imf::FrameBuffer fb;
        for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it) {
            auto& v = m[it.name()];
            v.assign(static_cast<size_t>(w) * h, 0);
            char* base = reinterpret_cast<char*>(v.data()) -
                         (static_cast<ptrdiff_t>(dw.min.y) * w + dw.min.x) * 4;
            fb.insert(it.name(),
                      Imf::Slice(it.channel().type, base, 4, 4 * static_cast<size_t>(w)));
        }
        in.setFrameBuffer(fb);
        in.readTiles(0, in.numXTiles(l) - 1, 0, in.numYTiles(l) - 1, l);
    }
    return out;
}

}  // namespace

TEST(ExrWriter, TiledAndMipMappedFilesMatchTheCppWriterOnEveryLevel) {
    // 37 x 53 with 8 x 16 tiles: partial tiles at the right and bottom of every level; MIP levels
    // rounded down (37x53, 18x26, ..., 1x1). Both writers, read back level by level.
    for (const Case& c :
         {Case{"zip", SampleType::Half, false}, Case{"zips", SampleType::Float, false},
          Case{"none", SampleType::Half, true}, Case{"zip", SampleType::Half, true}}) {
        for (bool mip : {false, true}) {
            SCOPED_TRACE(c.compression + (mip ? " mip" : " one level") + (c.noise ? " noise" : ""));
            std::vector<Data> lc, li;
            std::string uc, ui;
            const std::string core = write_tiled(c, "core", 37, 53, 8, 16, mip, lc, &uc);
            const std::string imf = write_tiled(c, "imf", 37, 53, 8, 16, mip, li, &ui);
            EXPECT_EQ(uc, "core");
            EXPECT_EQ(ui, "imf");
            Imf::Header hc, hi;
            const auto bc = read_tiled_bits(core, &hc), bi = read_tiled_bits(imf, &hi);
            ASSERT_EQ(bc.size(), mip ? 6u : 1u);  // 53 -> 26 -> 13 -> 6 -> 3 -> 1
            ASSERT_EQ(bc.size(), bi.size());
            EXPECT_EQ(hc.tileDescription().xSize, 8u);
            EXPECT_EQ(hc.tileDescription().mode, mip ? Imf::MIPMAP_LEVELS : Imf::ONE_LEVEL);
            EXPECT_EQ(hc.tileDescription().roundingMode, Imf::ROUND_DOWN);
            ASSERT_NE(hc.findTypedAttribute<Imf::StringAttribute>("textureformat"), nullptr);
            for (size_t l = 0; l < bc.size(); ++l) {
                EXPECT_EQ(bc[l], bi[l]) << "level " << l;
                // And the samples are the ones given (bin 0 and alpha of every level).
                const Data& d = lc[l];
                const size_t n = static_cast<size_t>(d.w) * d.h;
                const auto& t0 = bc[l].at(reflective_channel_name(380.0));
                for (size_t i = 0; i < n; ++i) {
                    uint32_t want;
                    if (c.type == SampleType::Half)
                        want = d.half[i];
                    else
                        std::memcpy(&want, &d.flt[i], 4);
                    ASSERT_EQ(t0[i], want) << "level " << l << " pixel " << i;
                    uint32_t a;
                    std::memcpy(&a, &d.alpha[i], 4);
                    ASSERT_EQ(bc[l].at("A")[i], a);
                }
            }
            unlink(core.c_str());
            unlink(imf.c_str());
        }
    }
}
