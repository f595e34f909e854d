// --update decides by the source's identity recorded in the output's header:
// spectex:sourceSize, spectex:sourceMtime and spectex:sourceHash (FNV-1a 64 of the source's bytes,
// computed here independently). A source replaced by an older-dated file is rebuilt; a source
// touched without a change is not.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

std::string fnv1a64_of_file(const std::string& path) {
    const std::string bytes = read_file(path);
    uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : bytes) h = (h ^ c) * 0x100000001b3ull;
    char buf[32];
    std::snprintf(buf, sizeof buf, "fnv1a64:%016llx", static_cast<unsigned long long>(h));
    return buf;
}

std::string mtime_of(const std::string& path) {
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) return "";
    char buf[48];
    std::snprintf(buf, sizeof buf, "%lld.%09ld", static_cast<long long>(st.st_mtim.tv_sec),
                  st.st_mtim.tv_nsec);
    return buf;
}

void set_mtime(const std::string& path, time_t sec, long nsec = 0) {
    struct timespec ts[2] = {{sec, nsec}, {sec, nsec}};
    ASSERT_EQ(::utimensat(AT_FDCWD, path.c_str(), ts, 0), 0) << path;
}

}  // namespace

TEST(UpdateIdentity, HeaderRecordsTheSourcesSizeTimeAndHash) {
    ScratchDir d;
    // PNG and JPEG read in order; TIFF and EXR readers seek (directories, offset tables), and a
    // tiled TIFF is read whole: the hash must still be of the bytes in file order.
    write_pattern_png(d / "a.png", 1, 40, 30);
    std::vector<uint8_t> px(64 * 48 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 7) & 255);
    write_image(d / "b.tif", 64, 48, 3, OIIO::TypeDesc::UINT8, px.data());
    write_image(d / "c.tif", 64, 48, 3, OIIO::TypeDesc::UINT8, px.data(), {}, 16);
    write_image(d / "d.jpg", 64, 48, 3, OIIO::TypeDesc::UINT8, px.data());
    std::vector<float> fpx(px.begin(), px.end());
    for (float& v : fpx) v /= 255.0f;
    write_image(d / "e.exr", 64, 48, 3, OIIO::TypeDesc::FLOAT, fpx.data());
    write_image(d / "f.tga", 64, 48, 3, OIIO::TypeDesc::UINT8, px.data());
    write_pattern_ppm(d / "g.ppm", 1);
    for (const char* name : {"a.png", "b.tif", "c.tif", "d.jpg", "e.exr", "f.tga", "g.ppm"}) {
        const std::string in = d / name, out = d / (std::string(name) + ".spectral.exr");
        const RunResult r = run_spectex({"bake", in, "-o", out});
        ASSERT_EQ(r.status, 0) << name << ": " << r.err;
        const ExrImage img = read_exr(out);
        struct stat st;
        ASSERT_EQ(::stat(in.c_str(), &st), 0);
        EXPECT_EQ(img.attr("spectex:sourceSize"), std::to_string(st.st_size)) << name;
        EXPECT_EQ(img.attr("spectex:sourceMtime"), mtime_of(in)) << name;
        EXPECT_EQ(img.attr("spectex:sourceHash"), fnv1a64_of_file(in)) << name;
    }
}

TEST(UpdateIdentity, ASourceReplacedByAnOlderDatedFileIsRebuilt) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "a.exr"}).status, 0);
    const std::string before = read_exr(d / "a.exr").attr("spectex:sourceHash");
    // A restore (or rsync -t, a checkout) puts other bytes in place with a date older than the
    // output.
    write_pattern_png(d / "a.png", 2);
    set_mtime(d / "a.png", 946684800);  // 2000-01-01
    const RunResult r =
        run_spectex({"bake", d / "a.png", "-o", d / "a.exr", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"ok\""), 1u) << r.out;
    const ExrImage img = read_exr(d / "a.exr");
    EXPECT_NE(img.attr("spectex:sourceHash"), before);
    EXPECT_EQ(img.attr("spectex:sourceHash"), fnv1a64_of_file(d / "a.png"));
    EXPECT_EQ(img.attr("spectex:sourceMtime"), "946684800.000000000");
}

TEST(UpdateIdentity, AReplacementOfTheSameSizeAndAnOlderDateIsRebuilt) {
    ScratchDir d;
    write_pattern_ppm(d / "a.ppm", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.ppm", "-o", d / "a.exr"}).status, 0);
    write_pattern_ppm(d / "a.ppm", 2);
    ASSERT_EQ(read_file(d / "a.ppm").size(), 59u);
    set_mtime(d / "a.ppm", 946684800);
    const RunResult r =
        run_spectex({"bake", d / "a.ppm", "-o", d / "a.exr", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"ok\""), 1u) << r.out;
    EXPECT_EQ(read_exr(d / "a.exr").attr("spectex:sourceSize"), "59");
    EXPECT_EQ(read_exr(d / "a.exr").attr("spectex:sourceHash"), fnv1a64_of_file(d / "a.ppm"));
}

TEST(UpdateIdentity, ATouchedSourceWithTheSameBytesIsUpToDate) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    write_pattern_png(d / "b.png", 2);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", d / "b.png", "--output-dir", d / "out"}).status, 0);
    RunResult r = run_spectex(
        {"bake", d / "a.png", d / "b.png", "--output-dir", d / "out", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(
        occurrences(
            r.out,
            "\"reason\":\"up to date: same settings hash, source size and modification time\""),
        2u)
        << r.out;
    // A checkout rewrites a with the same bytes and a new date; older or newer, it stays up to
    // date.
    set_mtime(d / "a.png", time(nullptr) + 100);
    set_mtime(d / "b.png", 946684800);
    r = run_spectex(
        {"bake", d / "a.png", d / "b.png", "--output-dir", d / "out", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"skipped\""), 2u) << r.out;
    EXPECT_EQ(occurrences(r.out, "its modification time changed"), 2u) << r.out;
    EXPECT_NE(r.err.find("0 baked, 2 up to date"), std::string::npos) << r.err;
}

TEST(UpdateIdentity, AnOutputThatDoesNotRecordItsSourceIsRebuilt) {
    ScratchDir d;
    write_pattern_png(d / "a.png", 1);
    ASSERT_EQ(run_spectex({"bake", d / "a.png", "-o", d / "a.exr"}).status, 0);
    // An output made before the identity was recorded: rename the attributes in place (same
    // length), so that the header no longer holds them.
    {
        std::string bytes = read_file(d / "a.exr");
        for (const std::string key :
             {"spectex:sourceHash", "spectex:sourceSize", "spectex:sourceMtime"}) {
            const size_t at = bytes.find(key + std::string(1, '\0'));
            ASSERT_NE(at, std::string::npos) << key;
            bytes[at + key.size() - 1] = 'X';
        }
        FILE* f = std::fopen((d / "a.exr").c_str(), "wb");
        ASSERT_NE(f, nullptr);
        std::fwrite(bytes.data(), 1, bytes.size(), f);
        std::fclose(f);
    }
    ASSERT_FALSE(read_exr(d / "a.exr").has_attr("spectex:sourceHash"));
    const RunResult r =
        run_spectex({"bake", d / "a.png", "-o", d / "a.exr", "--update", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(occurrences(r.out, "\"status\":\"ok\""), 1u) << r.out;
    EXPECT_TRUE(read_exr(d / "a.exr").has_attr("spectex:sourceHash"));
}
