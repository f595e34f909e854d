// The compression table (io/exr_compression.h) against OpenEXR itself (ids, chunk heights, which
// compressions change samples), and the lists that cannot be generated from it
// (docs/file-format.md, the man page) against the table.
#include "io/exr_compression.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>
#include <openexr.h>
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "base/error.h"
#include "base/half.h"
#include "io/atomic_file.h"
#include "io/exr_core_writer.h"
#include "io/spectral_exr_info.h"
#include "io/spectral_exr_writer.h"

using namespace spectex;

namespace {

constexpr int kWidth = 16, kHeight = 40, kBins = 3;

// Unique to this process (the tests remove what they write).
std::string temp_name(const std::string& tag) {
    return "/tmp/spectex-comp-" + std::to_string(getpid()) + "-" + tag + ".exr";
}

// A small file through spectex's writer (whichever back end the table names): kBins spectral
// channels and the R, G, B preview, all of `type`, with random samples in [0, 1).
std::string write_file(const ExrCompression& c, SampleType type) {
    const size_t n = static_cast<size_t>(kWidth) * kHeight;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<float> flt(n * kBins), r(n), g(n), b(n);
    for (auto& v : flt) v = u(rng);
    for (size_t i = 0; i < n; ++i) r[i] = u(rng), g[i] = u(rng), b[i] = u(rng);
    std::vector<uint16_t> half(flt.size());
    for (size_t i = 0; i < flt.size(); ++i) half[i] = float_to_half(flt[i]);

    SpectralExrLayout L;
    L.width = L.full_width = kWidth;
    L.height = L.full_height = kHeight;
    L.lambda = {450.0, 550.0, 650.0};
    L.type = type;
    L.preview = true;
    L.compression = c;
    const std::string path = temp_name(c.name + (type == SampleType::Half ? "-half" : "-float"));
    AtomicFile file(path);
    SpectralExrWriter w(file, L);
    const void* spectral =
        type == SampleType::Half ? static_cast<const void*>(half.data()) : flt.data();
    w.write_rows(kHeight, spectral, n, nullptr, r.data(), g.data(), b.data());
    w.finish();
    file.commit();
    return path;
}

// Every sample of every channel, as float, channels in the file's order.
std::vector<float> read_samples(const std::string& path) {
    Imf::InputFile in(path.c_str());
    const Imath::Box2i dw = in.header().dataWindow();
    const size_t n = static_cast<size_t>(kWidth) * kHeight;
    std::vector<std::string> names;
    const Imf::ChannelList& channels = in.header().channels();
    for (auto it = channels.begin(); it != channels.end(); ++it) names.push_back(it.name());
    std::vector<float> out(names.size() * n);
    Imf::FrameBuffer fb;
    for (size_t k = 0; k < names.size(); ++k)
        fb.insert(names[k], Imf::Slice::Make(Imf::FLOAT, out.data() + k * n, dw, sizeof(float),
                                             sizeof(float) * kWidth));
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    return out;
}

std::string read_text(const std::string& relative) {
    std::ifstream f(std::string(SPECTEX_TEST_SOURCE_DIR) + "/" + relative);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
}

// "a, b or c", "a|b|c", "a/b/c" -> {a, b, c}
std::vector<std::string> split_list(std::string s) {
    s = std::regex_replace(s, std::regex(" or |, |\\||/"), " ");
    std::vector<std::string> v;
    std::istringstream in(s);
    for (std::string w; in >> w;) v.push_back(w);
    return v;
}

std::vector<std::string> core_names() {
    std::vector<std::string> v;
    for (const auto& c : ExrCompression::all())
        if (c.core_writer) v.push_back(c.name);
    return v;
}

// Each capture of `re` in `text`, split into names.
std::vector<std::vector<std::string>> lists_in(const std::string& text, const std::string& re) {
    std::vector<std::vector<std::string>> out;
    const std::regex r(re);
    for (std::sregex_iterator it(text.begin(), text.end(), r), end; it != end; ++it)
        out.push_back(split_list((*it)[1].str()));
    return out;
}

}  // namespace

TEST(ExrCompression, IdsAreTheTableOrderAndNamesAreUnique) {
    const auto& t = ExrCompression::all();
    ASSERT_FALSE(t.empty());
    for (size_t i = 0; i < t.size(); ++i) {
        EXPECT_EQ(t[i].id, static_cast<int>(i)) << t[i].name;
        EXPECT_EQ(ExrCompression::find(t[i].id), &t[i]);
        EXPECT_EQ(ExrCompression::find(t[i].name), &t[i]);
        EXPECT_EQ(ExrCoreWriter::supports(t[i].name), t[i].core_writer) << t[i].name;
    }
    EXPECT_EQ(ExrCompression::find(static_cast<int>(t.size())), nullptr);
    EXPECT_EQ(ExrCompression::find("zstd"), nullptr);
    EXPECT_EQ(ExrCompression::list(", ", " or "),
              "none, rle, zips, zip, piz, pxr24 (lossy for float), b44 (lossy for half), b44a "
              "(lossy for half), dwaa (lossy) or dwab (lossy)");
    try {
        ExrCompression::parse("zstd");
        FAIL() << "parse accepted an unknown name";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()),
                  "unknown compression 'zstd' (known: none, rle, zips, zip, piz, pxr24 (lossy for "
                  "float), b44 (lossy for half), b44a (lossy for half), dwaa (lossy), dwab "
                  "(lossy))");
    }
}

// The header spectex writes for each compression carries the table's id; OpenEXR's core gives the
// chunk height the table says, and the header reader names it as the table does.
TEST(ExrCompression, WrittenIdChunkHeightAndNameAreOpenExrs) {
    for (const auto& c : ExrCompression::all()) {
        const std::string path = write_file(c, SampleType::Half);
        exr_context_t ctx = nullptr;
        exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
        ASSERT_EQ(exr_start_read(&ctx, path.c_str(), &init), EXR_ERR_SUCCESS) << c.name;
        exr_compression_t id;
        int32_t lines = 0;
        ASSERT_EQ(exr_get_compression(ctx, 0, &id), EXR_ERR_SUCCESS);
        ASSERT_EQ(exr_get_scanlines_per_chunk(ctx, 0, &lines), EXR_ERR_SUCCESS);
        exr_finish(&ctx);
        EXPECT_EQ(static_cast<int>(id), c.id) << c.name;
        EXPECT_EQ(lines, c.lines_per_chunk) << c.name;
        EXPECT_EQ(read_spectral_exr_info(path).compression, c.name);
        unlink(path.c_str());
    }
}

// Lossy means some sample of a spectex file (spectral or preview, half or float) reads back other
// than it does from the uncompressed file.
TEST(ExrCompression, LossyIsWhetherOpenExrChangesSamples) {
    for (SampleType type : {SampleType::Half, SampleType::Float}) {
        const std::string ref_path = write_file(*ExrCompression::find("none"), type);
        const std::vector<float> ref = read_samples(ref_path);
        unlink(ref_path.c_str());
        for (const auto& c : ExrCompression::all()) {
            const std::string path = write_file(c, type);
            const bool changed = read_samples(path) != ref;
            unlink(path.c_str());
            // pxr24 keeps half exactly, b44 keeps float exactly: each is lossy for one type only.
            const bool b44 = c.name == "b44" || c.name == "b44a";
            const bool expect = c.lossy && !(c.name == "pxr24" && type == SampleType::Half) &&
                                !(b44 && type == SampleType::Float);
            EXPECT_EQ(changed, expect) << c.name << (type == SampleType::Half ? " half" : " float");
            EXPECT_EQ(c.lossy_for(type == SampleType::Half), expect) << c.name;
        }
    }
}

// docs/file-format.md and the man page are written by hand: their lists must be the table's.
TEST(ExrCompressionDocs, ReadmeAndManPageListTheTable) {
    const std::string readme = read_text("docs/file-format.md"), man = read_text("man/spectex.1");
    ASSERT_FALSE(readme.empty());
    ASSERT_FALSE(man.empty());
    const std::vector<std::string> all = ExrCompression::names(), core = core_names();

    // docs/file-format.md: "`--compression\n  none|rle|...` (default zip)" and
    // "- none/zips/zip files (the default)".
    const auto readme_all = lists_in(readme, "--compression\\s+([a-z0-9]+(?:\\|[a-z0-9]+)+)`");
    ASSERT_EQ(readme_all.size(), 1u) << "docs/file-format.md: no `--compression a|b|...` list";
    EXPECT_EQ(readme_all[0], all)
        << "docs/file-format.md's --compression list is not the table's (io/exr_compression.cpp)";
    const auto readme_core =
        lists_in(readme, "\n- ([a-z0-9]+(?:/[a-z0-9]+)+) files \\(the default\\)");
    ASSERT_EQ(readme_core.size(), 1u)
        << "docs/file-format.md: no list of the core writer's compressions";
    EXPECT_EQ(readme_core[0], core) << "docs/file-format.md's core-writer list is not the table's";

    // man: ".BI \%\-\-compression " \%NAME"" then the list on the next line (where it has one), and
    // "Files compressed with none, zips or zip (the default)".
    const auto man_all =
        lists_in(man, "\\.BI \\\\%\\\\-\\\\-compression \" \\\\%NAME\"\n([a-z0-9, ]+)\n");
    ASSERT_EQ(man_all.size(), 1u) << "man/spectex.1: no --compression list";
    EXPECT_EQ(man_all[0], all) << "man/spectex.1's --compression list is not the table's";
    const auto man_core = lists_in(man, "Files compressed with ([a-z0-9, ]+) \\(the default\\)");
    ASSERT_EQ(man_core.size(), 1u) << "man/spectex.1: no list of the core writer's compressions";
    EXPECT_EQ(man_core[0], core) << "man/spectex.1's core-writer list is not the table's";
}
