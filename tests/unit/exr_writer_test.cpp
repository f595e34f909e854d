// The spectral EXR writer, both back ends (openexr_core + libdeflate, and OpenEXR's C++ library),
// read back with OpenEXR's C++ reader: every sample's bits, for every compression the core writer
// takes, odd sizes and origins, strips that do not line up with chunks, incompressible blocks.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
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

#include "io/atomic_file.h"
#include "io/exr_core_writer.h"
#include "io/spectral_exr_writer.h"
#include "spectral/half.h"
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
    std::vector<uint16_t> half;   // bins planes of w*h
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
            const float v = noise ? u(rng) : 0.5f + 0.4f * std::sin(0.05f * k + 0.001f * static_cast<float>(i));
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
std::string write(const Data& d, const Case& c, const std::string& writer, int threads, const std::vector<int>& strips,
                  std::string* used = nullptr, SpectralExrWriter::Timing* timing = nullptr) {
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
                                  ? reinterpret_cast<const char*>(d.half.data() + k * n + static_cast<size_t>(y) * d.w)
                                  : reinterpret_cast<const char*>(d.flt.data() + k * n + static_cast<size_t>(y) * d.w);
            std::memcpy(planes.data() + k * rows_n * es, src, rows_n * es);
        }
        const size_t off = static_cast<size_t>(y) * d.w;
        wr.write_rows(rows, planes.data(), rows_n, d.alpha.data() + off, d.r.data() + off, d.g.data() + off,
                      d.b.data() + off);
        y += rows;
    }
    wr.finish();
    if (timing) *timing = wr.timing();
    file.commit();
    return path;
}

// Reads every channel's raw bits (half as uint16, float as uint32) with OpenEXR's C++ reader.
std::map<std::string, std::vector<uint32_t>> read_bits(const std::string& path, Imf::Header* header = nullptr) {
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
        char* base = reinterpret_cast<char*>(v.data()) - (static_cast<ptrdiff_t>(dw.min.y) * w + dw.min.x) * 4;
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
    EXPECT_EQ(header.compression(), static_cast<Imf::Compression>(ExrCompression::parse(c.compression).id));
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
        {"zip", SampleType::Half, false},  {"zip", SampleType::Half, true},  {"zip", SampleType::Float, false},
        {"zips", SampleType::Half, false}, {"zips", SampleType::Float, true}, {"none", SampleType::Half, false},
        {"none", SampleType::Float, true},
    };
    // 37 x 53: rows not a multiple of ZIP's 16; strips of 7, 1, 29 rows straddle chunks.
    for (const auto& c : cases) {
        SCOPED_TRACE(c.compression + (c.type == SampleType::Half ? " half" : " float") + (c.noise ? " noise" : ""));
        const Data d = make_data(37, 53, 9, c.noise, 11);
        std::string used;
        SpectralExrWriter::Timing t;
        const std::string core = write(d, c, "core", 2, {7, 1, 29}, &used, &t);
        EXPECT_EQ(used, "core");
        // Random half bits do not deflate: those chunks must take the stored-raw path.
        if (c.noise && c.type == SampleType::Half && c.compression != "none") EXPECT_GT(t.raw_chunks, 0);
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
    EXPECT_EQ(t.chunk_bytes, 16u * 256u * (401u * 2u + 3u * 2u + 4u));  // 401 + R,G,B half + A float
    expect_file_holds(p, d, c);
    unlink(p.c_str());
}

TEST(ExrWriter, OtherCompressionsAndTilesUseTheCppWriter) {
    const Data d = make_data(16, 16, 3, false, 1);
    std::string used;
    const std::string p = write(d, Case{"piz", SampleType::Half, false}, "auto", 1, {16}, &used);
    EXPECT_EQ(used, "imf");
    unlink(p.c_str());
    EXPECT_FALSE(ExrCoreWriter::supports("piz"));
    EXPECT_TRUE(ExrCoreWriter::supports("zip"));
}
