// Hard inputs: a corpus of broken, hostile, oddly shaped and out-of-range files generated into a
// scratch folder, each with its expected behaviour.
//
//   Failures: exit 1, stderr starts with "spectex: " and names the input, no output file and no
//   temporary file (<output>.spectex-XXXXXX.tmp) is left behind.
//   Successes: exit 0, an OpenEXR whose windows are the input's, finite spectra in [0, 1] under the
//   default policies, and notes/counts on stderr where the input needed them.
//
// The table of failing cases is in BrokenFiles below; shapes, values and colour metadata follow.
#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"
#include "png_bytes.h"

using namespace spectex_test;

namespace {

bool contains(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

void write_bytes(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// ---------------------------------------------------------------------------------------------
// Peak memory of spectex alone. A child's ru_maxrss includes the RSS it inherited from a fork of
// this (possibly large) test process, which exec records; so the measured run is launched from a
// fresh image: this binary re-executed with SPECTEX_TEST_MAXRSS_OUT set, which before main() forks
// and execs its arguments, waits, writes the grandchild's ru_maxrss (kB) to that file, and exits
// with the grandchild's status (128+signal when killed).

struct MaxRssLauncher {
    MaxRssLauncher() {
        const char* report = std::getenv("SPECTEX_TEST_MAXRSS_OUT");
        if (!report) return;
        std::string cmdline = read_file("/proc/self/cmdline");
        std::vector<std::string> args;
        size_t pos = 0;
        while (pos < cmdline.size()) {
            size_t z = cmdline.find('\0', pos);
            if (z == std::string::npos) z = cmdline.size();
            args.push_back(cmdline.substr(pos, z - pos));
            pos = z + 1;
        }
        if (args.size() < 2) _exit(122);
        std::vector<char*> argv;
        for (size_t i = 1; i < args.size(); ++i) argv.push_back(args[i].data());
        argv.push_back(nullptr);
        unsetenv("SPECTEX_TEST_MAXRSS_OUT");
        pid_t pid = fork();
        if (pid == 0) {
            execv(argv[0], argv.data());
            _exit(127);
        }
        int st = 0;
        struct rusage ru {};
        if (pid < 0 || wait4(pid, &st, 0, &ru) != pid) _exit(121);
        std::ofstream(report) << ru.ru_maxrss << "\n";
        _exit(WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st));
    }
} max_rss_launcher;

// ---------------------------------------------------------------------------------------------
// A child process with its peak memory and, optionally, another user.

struct ChildResult {
    int status = -1;  // exit status, or 128+signal
    long maxrss_kb = 0;
    double seconds = 0;
    std::string out, err;
};

ChildResult run_child(const std::vector<std::string>& args, int as_uid = -1) {
    ScratchDir io;
    const std::string out = io / "out", err = io / "err";
    const std::string rss_file = io / "maxrss";
    // As 'nobody' the launcher could not write its report: run spectex directly then.
    std::vector<std::string> argv_s;
    if (as_uid < 0) argv_s = {"/proc/self/exe"};
    argv_s.push_back(spectex_binary());
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv = c_array(argv_s);
    std::vector<std::string> env_s = environment_with(
        as_uid < 0 ? std::vector<std::string>{"SPECTEX_TEST_MAXRSS_OUT=" + rss_file}
                   : std::vector<std::string>{});
    std::vector<char*> envp = c_array(env_s);
    const auto t0 = std::chrono::steady_clock::now();
    pid_t pid = fork();
    if (pid == 0) {
        // Only async-signal-safe calls between fork and exec (the parent has threads).
        int fo = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
        int fe = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
        if (fo < 0 || fe < 0) _exit(125);
        dup2(fo, 1);
        dup2(fe, 2);
        if (as_uid >= 0) {
            // Raw syscalls: the child has one thread, and glibc's set*id wrappers are not
            // async-signal-safe.
            if (syscall(SYS_setgroups, 0, nullptr) != 0 ||
                syscall(SYS_setresgid, as_uid, as_uid, as_uid) != 0 ||
                syscall(SYS_setresuid, as_uid, as_uid, as_uid) != 0)
                _exit(124);
        }
        execve(argv[0], argv.data(), envp.data());
        const char msg[] = "test harness: execv failed\n";
        (void)!write(2, msg, sizeof msg - 1);
        _exit(127);
    }
    ChildResult r;
    if (pid < 0) return r;
    int st = 0;
    struct rusage ru {};
    wait4(pid, &st, 0, &ru);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    r.maxrss_kb = ru.ru_maxrss;
    if (as_uid < 0) r.maxrss_kb = std::atol(read_file(rss_file).c_str());
    r.out = read_file(out);
    r.err = read_file(err);
    return r;
}

// ---------------------------------------------------------------------------------------------
// Hand-made PNGs (stored deflate blocks: no zlib needed), for what OIIO will not write: palette
// images and headers that lie about their size.

using png_bytes::be32;
using png_bytes::png_chunk;
using png_bytes::zlib_stored;

std::string png_ihdr(uint32_t w, uint32_t h, int depth, int colour_type) {
    std::string d = be32(w) + be32(h);
    d += static_cast<char>(depth);
    d += static_cast<char>(colour_type);
    d += std::string(3, '\0');  // deflate, adaptive filtering, no interlace
    return png_chunk("IHDR", d);
}

const std::string kPngSignature("\x89PNG\r\n\x1a\n", 8);

// A palette PNG: `indices` holds one palette index per pixel, packed at `depth` bits.
std::string palette_png(int w, int h, int depth, const std::vector<uint8_t>& palette_rgb,
                        const std::vector<int>& indices) {
    std::string raw;
    for (int y = 0; y < h; ++y) {
        raw += '\0';  // filter: none
        std::string row((static_cast<size_t>(w) * depth + 7) / 8, '\0');
        for (int x = 0; x < w; ++x) {
            int bit = x * depth;
            int v = indices[static_cast<size_t>(y * w + x)];
            row[static_cast<size_t>(bit / 8)] |= static_cast<char>(v << (8 - depth - bit % 8));
        }
        raw += row;
    }
    std::string plte(palette_rgb.begin(), palette_rgb.end());
    return kPngSignature + png_ihdr(static_cast<uint32_t>(w), static_cast<uint32_t>(h), depth, 3) +
           png_chunk("PLTE", plte) + png_chunk("IDAT", zlib_stored(raw)) + png_chunk("IEND", "");
}

// A PNG whose IHDR claims w x h RGB8 with one row of (stored) data: enormous on paper, tiny on
// disk.
std::string lying_png(uint32_t w, uint32_t h) {
    std::string row(1 + 3 * std::min<uint32_t>(w, 4096), '\0');
    return kPngSignature + png_ihdr(w, h, 8, 2) + png_chunk("IDAT", zlib_stored(row)) +
           png_chunk("IEND", "");
}

// An OpenEXR whose header claims w x h (half RGB) and whose pixels were never written.
void lying_exr(const std::string& path, int w, int h) {
    Imf::Header hdr(w, h);
    hdr.channels().insert("R", Imf::Channel(Imf::HALF));
    hdr.channels().insert("G", Imf::Channel(Imf::HALF));
    hdr.channels().insert("B", Imf::Channel(Imf::HALF));
    Imf::OutputFile f(path.c_str(), hdr);  // the destructor writes the (empty) line offset table
}

std::vector<uint8_t> noise8(size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::vector<uint8_t> v(n);
    for (auto& x : v) x = static_cast<uint8_t>(rng() & 0xff);
    return v;
}

void write_rgb8(const std::string& path, int w, int h, unsigned seed = 1) {
    auto px = noise8(static_cast<size_t>(w) * h * 3, seed);
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
}

// The checks made after every failure.
void expect_clean_failure(const std::string& what, int status, const std::string& err,
                          const std::string& input, const std::string& output) {
    SCOPED_TRACE(what);
    EXPECT_EQ(status, 1) << err;
    EXPECT_EQ(err.rfind("spectex: ", 0), 0u) << "stderr does not start with 'spectex: ':\n" << err;
    EXPECT_TRUE(contains(err, input)) << "stderr does not name " << input << ":\n" << err;
    struct stat st;
    EXPECT_NE(::lstat(output.c_str(), &st), 0) << output << " exists after a failed bake";
    auto tmp = temp_files_in(dir_of(output));
    EXPECT_TRUE(tmp.empty()) << "temporary file left: " << (tmp.empty() ? "" : tmp.front());
}

// Every spectral sample finite and in [lo, hi].
void expect_spectra_in(const ExrImage& img, float lo, float hi) {
    size_t bad = 0;
    std::string first;
    for (const auto& [l, name] : spectral_channels(img))
        for (float v : img.pixels.at(name))
            if (!std::isfinite(v) || v < lo || v > hi) {
                if (!bad++) first = name + " = " + std::to_string(v);
            }
    EXPECT_EQ(bad, 0u) << "samples outside [" << lo << ", " << hi << "], first " << first;
}

bool same_pixels(const ExrImage& a, const ExrImage& b, std::string* why) {
    if (a.channel_names != b.channel_names) return *why = "channels differ", false;
    if (a.width != b.width || a.height != b.height) return *why = "sizes differ", false;
    for (const auto& n : a.channel_names) {
        const auto &pa = a.pixels.at(n), &pb = b.pixels.at(n);
        for (size_t i = 0; i < pa.size(); ++i)
            if (std::memcmp(&pa[i], &pb[i], sizeof(float)) != 0) {
                *why = n + " differs at sample " + std::to_string(i) + ": " +
                       std::to_string(pa[i]) + " vs " + std::to_string(pb[i]);
                return false;
            }
    }
    return true;
}

}  // namespace

// =============================================================================================
// Broken files: the table.

namespace {

struct BrokenCase {
    const char* name;
    // Makes the input in `dir` and returns its path.
    std::function<std::string(const ScratchDir& dir)> make;
    std::vector<std::string> extra_args;
    std::vector<std::string> err_must_contain;  // besides "spectex: " and the input's path
};

std::string truncated_copy(const ScratchDir& d, const std::string& full, const std::string& cut,
                           double keep) {
    std::string bytes = read_file(full);
    write_bytes(cut,
                bytes.substr(0, static_cast<size_t>(static_cast<double>(bytes.size()) * keep)));
    return cut;
}

std::vector<BrokenCase> broken_cases() {
    return {
        {"zero_bytes_png",
         [](const ScratchDir& d) {
             write_bytes(d / "empty.png", "");
             return d / "empty.png";
         },
         {},
         {"empty"}},
        {"zero_bytes_exr",
         [](const ScratchDir& d) {
             write_bytes(d / "empty.exr", "");
             return d / "empty.exr";
         },
         {},
         {"empty"}},
        {"truncated_png_half",
         [](const ScratchDir& d) {
             write_rgb8(d / "full.png", 64, 64);
             return truncated_copy(d, d / "full.png", d / "cut.png", 0.5);
         },
         {},
         {}},
        {"truncated_png_header_only",
         [](const ScratchDir& d) {
             write_rgb8(d / "full.png", 64, 64);
             return truncated_copy(d, d / "full.png", d / "cut.png", 0.02);
         },
         {},
         {}},
        {"truncated_jpeg_half",
         [](const ScratchDir& d) {
             write_rgb8(d / "full.jpg", 64, 64);
             return truncated_copy(d, d / "full.jpg", d / "cut.jpg", 0.5);
         },
         {},
         {}},
        {"truncated_exr_half",
         [](const ScratchDir& d) {
             std::vector<float> px(64 * 64 * 3);
             std::mt19937 rng(3);
             for (auto& v : px) v = static_cast<float>(rng() % 1000) / 1000.0f;
             write_image(d / "full.exr", 64, 64, 3, OIIO::TypeDesc::FLOAT, px.data());
             return truncated_copy(d, d / "full.exr", d / "cut.exr", 0.5);
         },
         {},
         {}},
        {"truncated_exr_in_header",
         [](const ScratchDir& d) {
             std::vector<float> px(16 * 16 * 3, 0.5f);
             write_image(d / "full.exr", 16, 16, 3, OIIO::TypeDesc::FLOAT, px.data());
             std::string b = read_file(d / "full.exr");
             write_bytes(d / "cut.exr", b.substr(0, 40));
             return d / "cut.exr";
         },
         {},
         {}},
        {"text_named_png",
         [](const ScratchDir& d) {
             write_bytes(d / "notes.png", "This is not an image.\nJust some text.\n");
             return d / "notes.png";
         },
         {},
         {}},
        {"png_signature_then_garbage",
         [](const ScratchDir& d) {
             write_bytes(d / "sig.png", kPngSignature + std::string(200, '\x42'));
             return d / "sig.png";
         },
         {},
         {}},
        {"directory",
         [](const ScratchDir& d) {
             ::mkdir((d / "folder.png").c_str(), 0755);
             return d / "folder.png";
         },
         {},
         {"directory"}},
        {"missing_file", [](const ScratchDir& d) { return d / "nope.png"; }, {}, {"No such file"}},
        {"path_through_a_file",
         // "a.png/b.png": a component of the path is a regular file (ENOTDIR).
         [](const ScratchDir& d) {
             write_rgb8(d / "a.png", 2, 2);
             return d / "a.png/b.png";
         },
         {},
         {}},
        {"header_claims_100000x100000_png",
         [](const ScratchDir& d) {
             write_bytes(d / "huge.png", lying_png(100000, 100000));
             return d / "huge.png";
         },
         {},
         {"--max-pixels"}},
        {"header_claims_100000x100000_exr",
         [](const ScratchDir& d) {
             lying_exr(d / "huge.exr", 100000, 100000);
             return d / "huge.exr";
         },
         {},
         {"--max-pixels"}},
        {"header_claims_2147483647x2_png",
         [](const ScratchDir& d) {
             write_bytes(d / "wide.png", lying_png(0x7fffffffu, 2));
             return d / "wide.png";
         },
         {},
         {}},
        {"max_pixels_100_on_20x20",
         [](const ScratchDir& d) {
             write_rgb8(d / "20.png", 20, 20);
             return d / "20.png";
         },
         {"--max-pixels", "100"},
         {"--max-pixels"}},
        {"nan_error",
         [](const ScratchDir& d) {
             std::vector<float> px(4 * 3 * 3, 0.5f);
             px[3 * 5 + 1] = std::numeric_limits<float>::quiet_NaN();  // pixel (1, 1)
             write_image(d / "nan.exr", 4, 3, 3, OIIO::TypeDesc::FLOAT, px.data());
             return d / "nan.exr";
         },
         {"--nan", "error"},
         {"(1, 1)"}},
        {"inf_error",
         [](const ScratchDir& d) {
             std::vector<float> px(4 * 3 * 3, 0.5f);
             px[3 * 6 + 2] = -std::numeric_limits<float>::infinity();  // pixel (2, 1)
             write_image(d / "inf.exr", 4, 3, 3, OIIO::TypeDesc::FLOAT, px.data());
             return d / "inf.exr";
         },
         {"--nan", "error"},
         {"(2, 1)"}},
        {"out_of_range_error_above_1",
         [](const ScratchDir& d) {
             std::vector<float> px(4 * 3 * 3, 0.5f);
             px[3 * 11 + 0] = 1.5f;  // pixel (3, 2)
             write_image(d / "hot.exr", 4, 3, 3, OIIO::TypeDesc::FLOAT, px.data());
             return d / "hot.exr";
         },
         {"--out-of-range", "error"},
         {"(3, 2)", "--out-of-range"}},
        {"out_of_range_error_negative",
         [](const ScratchDir& d) {
             std::vector<float> px(4 * 3 * 3, 0.5f);
             px[3 * 0 + 2] = -0.25f;  // pixel (0, 0)
             write_image(d / "neg.exr", 4, 3, 3, OIIO::TypeDesc::FLOAT, px.data());
             return d / "neg.exr";
         },
         {"--out-of-range", "error"},
         {"(0, 0)"}},
    };
}

}  // namespace

TEST(HardInputs, BrokenFilesFailCleanly) {
    // spectex's own floor with its image libraries loaded (a clean bake of a 2x2 PNG: the image
    // module and OpenImageIO's libraries, which --version no longer loads, and the basis fit): a
    // failure may not allocate much beyond it.
    ScratchDir base;
    const std::vector<uint8_t> grey(2 * 2 * 3, 128);
    write_image(base / "ok.png", 2, 2, 3, OIIO::TypeDesc::UINT8, grey.data());
    const ChildResult ok = run_child({"bake", base / "ok.png", "-o", base / "ok.exr"});
    ASSERT_EQ(ok.status, 0) << ok.err;
    const long baseline_kb = ok.maxrss_kb;
    std::printf("  baseline (a bake of a 2x2 PNG): %ld kB peak\n", baseline_kb);
    for (const auto& c : broken_cases()) {
        ScratchDir d;
        const std::string in = c.make(d);
        const std::string out = d / "out.exr";
        std::vector<std::string> args{"bake", in, "-o", out};
        args.insert(args.end(), c.extra_args.begin(), c.extra_args.end());
        ChildResult r = run_child(args);
        const std::string what = std::string(c.name) + " (" + in + ")";
        expect_clean_failure(what, r.status, r.err, in, out);
        for (const auto& s : c.err_must_contain)
            EXPECT_TRUE(contains(r.err, s)) << what << ": no '" << s << "' in\n" << r.err;
        // Hostile headers must be refused before any allocation: well under 200 MB (a plain run
        // peaks near 135 MB, mostly libraries and the basis fit), quickly. Under AddressSanitizer
        // (tests/sanitize/run.sh sets ASAN_OPTIONS) shadow memory and quarantine triple that.
        const long limit_kb = (std::getenv("ASAN_OPTIONS") ? 600 : 200) * 1024;
        EXPECT_LT(r.maxrss_kb, limit_kb) << what << ": peak memory " << r.maxrss_kb << " kB";
        EXPECT_LT(r.maxrss_kb, baseline_kb + 64 * 1024)
            << what << ": peak memory " << r.maxrss_kb << " kB, " << baseline_kb
            << " kB for a clean bake";
        EXPECT_LT(r.seconds, 30.0) << what;
        std::printf("  %-34s exit %d, %5ld kB peak, %.2f s: %s", c.name, r.status, r.maxrss_kb,
                    r.seconds, r.err.empty() ? "(no message)\n" : r.err.c_str());
    }
}

TEST(HardInputs, UnreadableFile) {
    // Tests run as root, for whom chmod 000 does not stop reading: run spectex as 'nobody'
    // (uid 65534) on a mode-000 file in a world-writable folder. Skipped when the binary or its
    // data are not reachable by that user.
    ScratchDir d;
    ASSERT_EQ(::chmod(d.path().c_str(), 0777), 0);
    const std::string in = d / "secret.png", out = d / "out.exr";
    write_rgb8(in, 4, 4);
    ASSERT_EQ(::chmod(in.c_str(), 0), 0);
    if (::getuid() != 0) {
        ChildResult r = run_child({"bake", in, "-o", out});
        expect_clean_failure("unreadable", r.status, r.err, in, out);
        EXPECT_TRUE(contains(r.err, "Permission denied")) << r.err;
        return;
    }
    ChildResult probe = run_child({"--version"}, 65534);
    if (probe.status != 0)
        GTEST_SKIP() << "spectex cannot run as uid 65534 here (" << probe.status << ")";
    ChildResult r = run_child({"bake", in, "-o", out}, 65534);
    expect_clean_failure("unreadable", r.status, r.err, in, out);
    EXPECT_TRUE(contains(r.err, "Permission denied")) << r.err;
}

TEST(HardInputs, MaxPixelsIsInclusive) {
    ScratchDir d;
    const std::string in = d / "10.png", out = d / "out.exr";
    write_rgb8(in, 10, 10);
    RunResult r = run_spectex({"bake", in, "-o", out, "--max-pixels", "100"});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(file_exists(out));
}

TEST(HardInputs, MisspeltColourSpaceSuggests) {
    ScratchDir d;
    const std::string in = d / "in.png", out = d / "out.exr";
    write_rgb8(in, 4, 4);
    RunResult r = run_spectex({"bake", in, "-o", out, "--colorspace", "srgbtx"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(r.err.rfind("spectex: ", 0), 0u) << r.err;
    EXPECT_TRUE(contains(r.err, "srgbtx")) << r.err;
    EXPECT_TRUE(contains(r.err, "srgb_tx")) << r.err;
    // The misspelling is the option's, not the file's; the message names the OCIO config in which
    // the name was looked up.
    EXPECT_FALSE(file_exists(out));
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

// =============================================================================================
// Shapes: all succeed; the output has the input's windows.

namespace {

ExrImage bake_ok(const std::string& in, const std::string& out,
                 const std::vector<std::string>& extra = {}, std::string* err = nullptr) {
    std::vector<std::string> args{"bake", in, "-o", out};
    args.insert(args.end(), extra.begin(), extra.end());
    RunResult r = run_spectex(args);
    EXPECT_EQ(r.status, 0) << in << ": " << r.err;
    if (err) *err = r.err;
    if (r.status != 0 || !file_exists(out)) return {};
    EXPECT_TRUE(temp_files_in(dir_of(out)).empty());
    return read_exr(out);
}

}  // namespace

TEST(HardInputs, SmallAndOddShapes) {
    const std::pair<int, int> shapes[] = {{1, 1},   {1, 37},  {37, 1},  {3, 5},
                                          {33, 17}, {257, 3}, {1, 1025}};
    for (auto [w, h] : shapes) {
        ScratchDir d;
        const std::string in = d / "in.png", out = d / "out.exr";
        write_rgb8(in, w, h, static_cast<unsigned>(w * 1000 + h));
        ExrImage img = bake_ok(in, out);
        EXPECT_EQ(img.width, w) << w << "x" << h;
        EXPECT_EQ(img.height, h) << w << "x" << h;
        EXPECT_EQ(spectral_channels(img).size(), kDefaultBins);
        expect_spectra_in(img, 0.0f, 1.0f);
    }
}

TEST(HardInputs, ExrDataWindowDiffersFromDisplayWindow) {
    ScratchDir d;
    const std::string in = d / "dw.exr", out = d / "out.exr";
    // 5x3 of data at (-2, 7) inside a 16x16 display window.
    OIIO::ImageSpec spec(5, 3, 3, OIIO::TypeDesc::HALF);
    spec.x = -2;
    spec.y = 7;
    spec.full_x = 0;
    spec.full_y = 0;
    spec.full_width = 16;
    spec.full_height = 16;
    std::vector<float> px(5 * 3 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<float>(i % 7) / 7.0f;
    auto o = OIIO::ImageOutput::create(in);
    ASSERT_TRUE(o && o->open(in, spec) && o->write_image(OIIO::TypeDesc::FLOAT, px.data()) &&
                o->close());
    ExrImage img = bake_ok(in, out);
    EXPECT_EQ(img.data_window.min.x, -2);
    EXPECT_EQ(img.data_window.min.y, 7);
    EXPECT_EQ(img.data_window.max.x, 2);
    EXPECT_EQ(img.data_window.max.y, 9);
    EXPECT_EQ(img.display_window.min.x, 0);
    EXPECT_EQ(img.display_window.max.x, 15);
    EXPECT_EQ(img.display_window.max.y, 15);
    expect_spectra_in(img, 0.0f, 1.0f);
}

TEST(HardInputs, MultiSubimageTiffTakesTheFirst) {
    ScratchDir d;
    const std::string in = d / "multi.tif", out = d / "out.exr", first = d / "first.tif",
                      ref = d / "ref.exr";
    auto o = OIIO::ImageOutput::create(in);
    ASSERT_TRUE(o && o->supports("multiimage"));
    OIIO::ImageSpec specs[2] = {OIIO::ImageSpec(6, 4, 3, OIIO::TypeDesc::UINT8),
                                OIIO::ImageSpec(3, 2, 3, OIIO::TypeDesc::UINT8)};
    auto p0 = noise8(6 * 4 * 3, 11), p1 = noise8(3 * 2 * 3, 12);
    ASSERT_TRUE(o->open(in, 2, specs));
    ASSERT_TRUE(o->write_image(OIIO::TypeDesc::UINT8, p0.data()));
    ASSERT_TRUE(o->open(in, specs[1], OIIO::ImageOutput::AppendSubimage));
    ASSERT_TRUE(o->write_image(OIIO::TypeDesc::UINT8, p1.data()));
    ASSERT_TRUE(o->close());
    write_image(first, 6, 4, 3, OIIO::TypeDesc::UINT8, p0.data());

    std::string err;
    ExrImage img = bake_ok(in, out, {}, &err);
    EXPECT_TRUE(contains(err, "2 subimages")) << err;
    EXPECT_TRUE(contains(err, "first")) << err;
    ExrImage expect = bake_ok(first, ref);
    std::string why;
    EXPECT_TRUE(same_pixels(img, expect, &why)) << why;
}

TEST(HardInputs, MipMappedExrTakesTheFirstLevel) {
    ScratchDir d;
    const std::string in = d / "mip.exr", out = d / "out.exr", top = d / "top.exr",
                      ref = d / "ref.exr";
    auto o = OIIO::ImageOutput::create(in);
    ASSERT_TRUE(o && o->supports("mipmap"));
    std::vector<std::vector<float>> levels;
    int w = 16, h = 8;
    OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::HALF);
    spec.tile_width = spec.tile_height = 8;
    spec.attribute("textureformat", "Plain Texture");
    spec.attribute("openexr:levelmode", 1);  // Imf::MIPMAP_LEVELS
    spec.attribute("openexr:roundingmode", 0);
    ASSERT_TRUE(o->open(in, spec));
    for (int level = 0; w >= 1 && h >= 1; ++level) {
        std::vector<float> px(static_cast<size_t>(w * h * 3));
        for (size_t i = 0; i < px.size(); ++i)
            px[i] = static_cast<float>((i * 7 + level) % 11) / 11.0f;
        if (level > 0) {
            OIIO::ImageSpec s(w, h, 3, OIIO::TypeDesc::HALF);
            s.tile_width = s.tile_height = 8;
            s.attribute("openexr:levelmode", 1);
            s.attribute("openexr:roundingmode", 0);
            ASSERT_TRUE(o->open(in, s, OIIO::ImageOutput::AppendMIPLevel)) << o->geterror();
        }
        ASSERT_TRUE(o->write_image(OIIO::TypeDesc::FLOAT, px.data())) << o->geterror();
        levels.push_back(px);
        if (w == 1 && h == 1) break;
        w = std::max(1, w / 2);
        h = std::max(1, h / 2);
    }
    ASSERT_TRUE(o->close());
    o.reset();
    ASSERT_GT(read_file(in).size(), 100u);
    // Reference: the top level alone, as a plain scanline EXR with the same pixels.
    {
        OIIO::ImageSpec s(16, 8, 3, OIIO::TypeDesc::HALF);
        auto t = OIIO::ImageOutput::create(top);
        ASSERT_TRUE(t && t->open(top, s) &&
                    t->write_image(OIIO::TypeDesc::FLOAT, levels[0].data()) && t->close());
    }
    std::string err;
    ExrImage img = bake_ok(in, out, {}, &err);
    EXPECT_EQ(img.width, 16);
    EXPECT_EQ(img.height, 8);
    EXPECT_TRUE(contains(err, "MIP levels")) << err;
    EXPECT_TRUE(contains(err, "first")) << err;
    ExrImage expect = bake_ok(top, ref);
    std::string why;
    EXPECT_TRUE(same_pixels(img, expect, &why)) << why;
}

TEST(HardInputs, PalettePngMatchesTheSameColoursAsRgb) {
    // Palette PNGs are made by hand (OIIO writes none): 8-bit indices and 4-bit packed indices on
    // an odd width. Each must bake exactly like the RGB PNG of the same colours.
    const std::vector<uint8_t> palette = {255, 0,   0,   0,   255, 0,   0, 0,
                                          255, 128, 128, 128, 10,  200, 30};
    for (int depth : {8, 4, 2}) {
        ScratchDir d;
        const int w = 7, h = 3;
        const int ncolours = depth == 2 ? 4 : 5;
        std::vector<int> idx(static_cast<size_t>(w * h));
        std::vector<uint8_t> rgb;
        for (size_t i = 0; i < idx.size(); ++i) {
            idx[i] = static_cast<int>((i * 3 + 1) % static_cast<size_t>(ncolours));
            for (int c = 0; c < 3; ++c) rgb.push_back(palette[static_cast<size_t>(3 * idx[i] + c)]);
        }
        std::vector<uint8_t> pal(palette.begin(), palette.begin() + 3 * ncolours);
        const std::string in = d / "pal.png", rgbin = d / "rgb.png";
        write_bytes(in, palette_png(w, h, depth, pal, idx));
        write_image(rgbin, w, h, 3, OIIO::TypeDesc::UINT8, rgb.data());
        ExrImage a = bake_ok(in, d / "pal.exr");
        ExrImage b = bake_ok(rgbin, d / "rgb.exr");
        std::string why;
        EXPECT_TRUE(same_pixels(a, b, &why)) << "palette depth " << depth << ": " << why;
    }
}

// A file of a format OpenImageIO decodes on its own terms bakes as the PNG of the pixels
// OpenImageIO decodes from it (all channels, 8-bit). GIF: its reader calls its four channels' alpha
// channel 4, one past the last: taken as given it read a fifth channel and shifted every pixel's
// channels (an opaque blue read as a translucent grey). WebP: probing its reader for a second frame
// left it unable to decode the first ("Couldn't decode subimage 0"): no WebP could be read.
TEST(HardInputs, GifAndWebpBakeAsThePngOfTheirDecodedPixels) {
    for (const std::string ext : {"gif", "webp"}) {
        SCOPED_TRACE(ext);
        ScratchDir d;
        const int w = 9, h = 5;
        std::vector<uint8_t> rgb;
        for (int i = 0; i < w * h; ++i)
            for (int c = 0; c < 3; ++c)
                rgb.push_back(static_cast<uint8_t>(
                    std::vector<int>{26, 128, 230, 200, 40, 90}[(i % 2) * 3 + c]));
        const std::string in = d / ("g." + ext), png = d / "g.png";
        write_image(in, w, h, 3, OIIO::TypeDesc::UINT8, rgb.data());
        auto src = OIIO::ImageInput::open(in);
        ASSERT_TRUE(src) << OIIO::geterror();
        const int nch = src->spec().nchannels;
        std::vector<uint8_t> decoded(static_cast<size_t>(w * h * nch));
        ASSERT_TRUE(src->read_image(0, 0, 0, nch, OIIO::TypeDesc::UINT8, decoded.data()));
        src->close();
        write_image(png, w, h, nch, OIIO::TypeDesc::UINT8, decoded.data());
        ExrImage a = bake_ok(in, d / "in.exr");
        ExrImage b = bake_ok(png, d / "png.exr");
        std::string why;
        EXPECT_TRUE(same_pixels(a, b, &why)) << why;
        const RunResult v = run_spectex({"verify", d / "in.exr", "--source", in});
        EXPECT_EQ(v.status, 0) << v.out << v.err;
    }
}

// A CMYK TIFF holds ink separations, which OpenImageIO hands over as they are (ink0..ink3): read
// by position they baked as R, G, B with black ink as alpha (100 % cyan: transparent black), exit
// 0, and verify passed it. Refused, naming the file and what to do, by bake and by verify.
TEST(HardInputs, InkSeparationsAreRefusedNotReadAsRgba) {
    ScratchDir d;
    std::vector<uint8_t> px(16 * 16 * 4, 0);
    for (size_t i = 0; i < px.size(); i += 4) px[i] = 255;  // cyan ink only
    const std::string tif = d / "cmyk.tif";
    write_image(tif, 16, 16, 4, OIIO::TypeDesc::UINT8, px.data(), {{"tiff:ColorSpace", "CMYK"}});
    {
        auto in = OIIO::ImageInput::open(tif);
        ASSERT_TRUE(in);
        ASSERT_EQ(in->spec().get_int_attribute("tiff:PhotometricInterpretation", -1), 5)
            << "the test file is not separated";
    }
    const RunResult r = run_spectex({"bake", tif, "-o", d / "out.exr"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(contains(r.err, tif + ": ink separations (CMYK)")) << r.err;
    EXPECT_FALSE(file_exists(d / "out.exr"));
    write_pattern_png(d / "p.png", 1, 16, 16);
    ASSERT_EQ(run_spectex({"bake", d / "p.png", "-o", d / "p.exr"}).status, 0);
    const RunResult v = run_spectex({"verify", d / "p.exr", "--source", tif});
    EXPECT_NE(v.status, 0) << v.out;
    EXPECT_TRUE(contains(v.err + v.out, "ink separations")) << v.err << v.out;
}

// OpenImageIO 2.4's Maya IFF reader expands run-length data unchecked: one changed byte of a valid
// file aborted spectex ("double free or corruption"), and in a batch it corrupted the heap the
// other files were baked with, every file reported ok. No IFF is opened, whatever its name says;
// the rest of a batch bakes.
TEST(HardInputs, MayaIffIsRefusedBeforeItsReaderRuns) {
    ScratchDir d;
    const std::string iff = d / "t.iff";
    std::vector<uint8_t> px(16 * 16 * 3, 90);
    write_image(iff, 16, 16, 3, OIIO::TypeDesc::UINT8, px.data());
    ASSERT_EQ(read_file(iff).substr(0, 4), "FOR4");
    write_bytes(d / "disguised.png", read_file(iff));
    write_pattern_png(d / "ok.png", 2);
    const RunResult r =
        run_spectex({"bake", iff, d / "disguised.png", d / "ok.png", "--output-dir", d / "out"});
    EXPECT_EQ(r.status, 1) << r.err;
    for (const std::string& f : {iff, d / "disguised.png"})
        EXPECT_TRUE(contains(r.err, f + ": Maya IFF is not read")) << r.err;
    EXPECT_TRUE(contains(r.err, "1 baked, 0 up to date, 2 failed of 3")) << r.err;
    EXPECT_TRUE(file_exists(d / "out/ok.exr"));
}

// Tiled inputs are read a band of tile rows at a time, and the bake's strips (rows of about 32 MB
// of spectral samples) do not fall on tile rows: a tiled TIFF of 48-row tiles, tall enough for
// several strips, bakes exactly as the scanline TIFF of the same pixels.
TEST(HardInputs, TiledInputsReadByBandsBakeAsScanlines) {
    ScratchDir d;
    const int w = 1500, h = 400;
    std::vector<uint8_t> px(static_cast<size_t>(w * h * 3));
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<uint8_t>((i * 2654435761u) >> 24);
    const std::string tiled = d / "tiled.tif", lines = d / "lines.tif";
    write_image(tiled, w, h, 3, OIIO::TypeDesc::UINT8, px.data(), {}, 48);
    write_image(lines, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
    ExrImage a = bake_ok(tiled, d / "tiled.exr");
    ExrImage b = bake_ok(lines, d / "lines.exr");
    std::string why;
    EXPECT_TRUE(same_pixels(a, b, &why)) << why;
}

TEST(HardInputs, SampleTypesAndChannelCounts) {
    // 8/16-bit PNG, half and float EXR, with 1 to 4 channels: all bake, spectra in [0, 1], A
    // present exactly when the input has alpha.
    struct T {
        const char* ext;
        OIIO::TypeDesc type;
        int nch;
    };
    const T cases[] = {{"png", OIIO::TypeDesc::UINT8, 1},  {"png", OIIO::TypeDesc::UINT8, 2},
                       {"png", OIIO::TypeDesc::UINT8, 4},  {"png", OIIO::TypeDesc::UINT16, 3},
                       {"png", OIIO::TypeDesc::UINT16, 4}, {"exr", OIIO::TypeDesc::HALF, 3},
                       {"exr", OIIO::TypeDesc::FLOAT, 4},  {"exr", OIIO::TypeDesc::FLOAT, 1},
                       {"tif", OIIO::TypeDesc::UINT16, 3}, {"tif", OIIO::TypeDesc::FLOAT, 3}};
    for (const auto& c : cases) {
        ScratchDir d;
        const int w = 9, h = 5;
        std::vector<float> px(static_cast<size_t>(w * h * c.nch));
        for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<float>((i * 37) % 101) / 100.0f;
        const std::string in = d / (std::string("in.") + c.ext), out = d / "out.exr";
        OIIO::ImageSpec spec(w, h, c.nch, c.type);
        auto o = OIIO::ImageOutput::create(in);
        ASSERT_TRUE(o && o->open(in, spec) && o->write_image(OIIO::TypeDesc::FLOAT, px.data()) &&
                    o->close());
        ExrImage img = bake_ok(in, out);
        SCOPED_TRACE(std::string(c.ext) + " " + c.type.c_str() + " x" + std::to_string(c.nch));
        EXPECT_EQ(img.width, w);
        expect_spectra_in(img, 0.0f, 1.0f);
        EXPECT_EQ(img.has("A"), c.nch == 2 || c.nch == 4);
    }
}

// =============================================================================================
// Values: NaN, infinities, negatives, values above 1 and denormals in a float EXR.

namespace {

// 8 pixels of float RGB: (0.5 grey), NaN, +Inf, -Inf, negative, >1, denormal, 0.25 grey.
std::vector<float> hostile_values() {
    const float nan = std::numeric_limits<float>::quiet_NaN(),
                inf = std::numeric_limits<float>::infinity();
    const float den = std::numeric_limits<float>::denorm_min() * 12345.0f;
    return {0.5f,  0.5f, 0.5f, nan,  0.2f, 0.3f, 0.1f, inf,  0.3f, 0.2f,  0.3f,  -inf,
            -0.5f, 0.2f, 0.3f, 2.0f, 3.0f, 4.0f, den,  -den, den,  0.25f, 0.25f, 0.25f};
}

}  // namespace

TEST(HardInputs, HostileValuesDefaultPolicies) {
    ScratchDir d;
    const std::string in = d / "vals.exr", out = d / "out.exr";
    auto px = hostile_values();
    write_image(in, 8, 1, 3, OIIO::TypeDesc::FLOAT, px.data());
    std::string err;
    ExrImage img = bake_ok(in, out, {"--type", "float"}, &err);
    ASSERT_EQ(img.width, 8);
    expect_spectra_in(img, 0.0f, 1.0f);
    // NaN, +Inf, -Inf: 3 pixels replaced; negative and >1: 2 pixels clamped (denormals are in range
    // on one side and negative on the other: -denormal is below 0, so that pixel is clamped too).
    EXPECT_TRUE(contains(err, "3 pixels had NaN/Inf")) << err;
    EXPECT_TRUE(contains(err, "clamped")) << err;
    EXPECT_TRUE(contains(err, in)) << err;
    // Counts once per file.
    EXPECT_EQ(err.find("clamped"), err.rfind("clamped")) << err;
    // The NaN/Inf pixels came out as if the bad channel were 0: no sample is NaN.
    // The >1 pixel clamps to white: a flat spectrum at 1 (within half/fit rounding).
    for (const auto& [l, name] : spectral_channels(img))
        EXPECT_NEAR(img.at(name, 5, 0), 1.0f, 1e-5) << name;
}

// A finite value far above 1 in an input whose transform is a power curve (a float TIFF read as
// sRGB): 1e30 overflowed the curve to infinity, which --nan replace made 0, so a pixel brighter
// than white baked black. Clamped, it is white; -1e30 in one channel is 0 in that channel.
TEST(HardInputs, HugeFiniteValuesClampLikeAnyValueAboveOne) {
    ScratchDir d;
    const std::string in = d / "huge.tif";
    std::vector<float> px = {1e30f, 1e30f, 1e30f, -1e30f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f};
    write_image(in, 3, 1, 3, OIIO::TypeDesc::FLOAT, px.data());
    std::string err;
    ExrImage img = bake_ok(in, d / "out.exr", {"--colorspace", "srgb_tx", "--type", "float"}, &err);
    EXPECT_TRUE(contains(err, "2 pixels had linear values outside [0, 1] and were clamped")) << err;
    EXPECT_FALSE(contains(err, "NaN/Inf")) << err;
    for (const auto& [l, name] : spectral_channels(img))
        EXPECT_NEAR(img.at(name, 0, 0), 1.0f, 1e-5) << name;
    // Pixel 1 integrates back to red 0 (its green and blue are pixel 2's grey).
    const RunResult s = run_spectex({"sample", d / "out.exr", "1,0"});
    ASSERT_EQ(s.status, 0) << s.err;
    const size_t at = s.out.find("linear Rec.709 ");
    ASSERT_NE(at, std::string::npos) << s.out;
    EXPECT_LT(std::fabs(std::stod(s.out.substr(at + 15))), 1e-3) << s.out;
}

TEST(HardInputs, OutOfRangeKeepKeepsValues) {
    ScratchDir d;
    const std::string in = d / "vals.exr", out = d / "out.exr";
    // grey 2.0 and grey -0.5, finite only.
    std::vector<float> px = {2.0f, 2.0f, 2.0f, -0.5f, -0.5f, -0.5f, 0.5f, 0.5f, 0.5f};
    write_image(in, 3, 1, 3, OIIO::TypeDesc::FLOAT, px.data());
    std::string err;
    ExrImage img = bake_ok(in, out, {"--out-of-range", "keep", "--type", "float"}, &err);
    ASSERT_EQ(img.width, 3);
    EXPECT_FALSE(contains(err, "clamped")) << err;
    // Grey g gives the flat spectrum g (the basis sums to one at every wavelength).
    for (const auto& [l, name] : spectral_channels(img)) {
        EXPECT_NEAR(img.at(name, 0, 0), 2.0f, 1e-4) << name;
        EXPECT_NEAR(img.at(name, 1, 0), -0.5f, 1e-4) << name;
        EXPECT_NEAR(img.at(name, 2, 0), 0.5f, 1e-4) << name;
    }
}

TEST(HardInputs, NanReplaceWithOutOfRangeKeepStillFinite) {
    ScratchDir d;
    const std::string in = d / "vals.exr", out = d / "out.exr";
    auto px = hostile_values();
    write_image(in, 8, 1, 3, OIIO::TypeDesc::FLOAT, px.data());
    ExrImage img = bake_ok(in, out, {"--out-of-range", "keep", "--type", "float"});
    for (const auto& [l, name] : spectral_channels(img))
        for (float v : img.pixels.at(name)) EXPECT_TRUE(std::isfinite(v)) << name;
}

TEST(HardInputs, HalfInputWithInfinities) {
    ScratchDir d;
    const std::string in = d / "h.exr", out = d / "out.exr";
    std::vector<float> px = {65504.0f, 0.0f, 0.0f,    std::numeric_limits<float>::infinity(),
                             0.1f,     0.1f, 6.0e-8f, 6.0e-8f,
                             6.0e-8f};  // max half, +Inf, half denormal
    // Written through float: OIIO converts to half.
    {
        OIIO::ImageSpec s(3, 1, 3, OIIO::TypeDesc::HALF);
        auto o = OIIO::ImageOutput::create(in);
        ASSERT_TRUE(o && o->open(in, s) && o->write_image(OIIO::TypeDesc::FLOAT, px.data()) &&
                    o->close());
    }
    std::string err;
    ExrImage img = bake_ok(in, out, {}, &err);
    expect_spectra_in(img, 0.0f, 1.0f);
    EXPECT_TRUE(contains(err, "NaN/Inf")) << err;
    EXPECT_TRUE(contains(err, "clamped")) << err;
}

// =============================================================================================
// Wide gamut and colour metadata.

// An alpha outside [0, 1] (a float input's) made T = A x spectrum leave [0, 1]: the bake passed
// silently and spectex's own verify failed the file, saying 196.875 % of its samples were out
// (a sample under a negative A was counted below and above). Alpha follows --out-of-range as the
// colour does, and verify counts each sample once.
TEST(HardInputs, AlphaOutsideZeroOneFollowsTheRangePolicy) {
    ScratchDir d;
    const std::string in = d / "a.exr";
    std::vector<float> px(4 * 4 * 4);
    for (size_t i = 0; i < 16; ++i) {
        px[4 * i] = px[4 * i + 1] = px[4 * i + 2] = 0.5f;
        px[4 * i + 3] = i == 0 ? 2.0f : i < 13 ? -0.5f : 0.75f;
    }
    write_image(in, 4, 4, 4, OIIO::TypeDesc::FLOAT, px.data());
    std::string err;
    ExrImage img = bake_ok(in, d / "clamped.exr", {}, &err);
    EXPECT_TRUE(
        contains(err, "13 pixels had linear values outside [0, 1] and were clamped (by up to 1)"))
        << err;
    EXPECT_EQ(img.pixels.at("A")[0], 1.0f);
    EXPECT_EQ(img.pixels.at("A")[1], 0.0f);
    const RunResult v = run_spectex({"verify", d / "clamped.exr", "--source", in});
    EXPECT_EQ(v.status, 0) << v.out << v.err;
    const RunResult e = run_spectex({"bake", in, "-o", d / "error.exr", "--out-of-range", "error"});
    EXPECT_EQ(e.status, 1) << e.err;
    EXPECT_TRUE(contains(e.err, in + ": alpha 2.000000 outside [0, 1] at pixel (0, 0)")) << e.err;
    // Kept, then judged as if it had not been: the share of samples out is at most 100 %.
    ExrImage kept = bake_ok(in, d / "kept.exr", {"--out-of-range", "keep"});
    EXPECT_EQ(kept.pixels.at("A")[1], -0.5f);
    hide_attributes(d / "kept.exr", {"spectex:outOfRange"});
    const RunResult k = run_spectex({"verify", d / "kept.exr"});
    EXPECT_EQ(k.status, 1) << k.out;
    const size_t at = k.out.find("outside [0, 1] by more than their rounding");
    ASSERT_NE(at, std::string::npos) << k.out;
    const std::string line = k.out.substr(at, k.out.find('\n', at) - at);
    const size_t open = line.find('(');
    ASSERT_NE(open, std::string::npos) << line;
    EXPECT_LE(std::stod(line.substr(open + 1)), 100.0) << line;
}

TEST(HardInputs, AcesCgSaturatedGreenIsClamped) {
    ScratchDir d;
    const std::string in = d / "green.exr", out = d / "out.exr";
    std::vector<float> px = {0.0f, 1.0f, 0.0f, 0.0f, 0.8f, 0.0f, 0.18f, 0.18f, 0.18f};
    write_image(in, 3, 1, 3, OIIO::TypeDesc::FLOAT, px.data());
    std::string err;
    ExrImage img = bake_ok(in, out, {"--colorspace", "acescg"}, &err);
    EXPECT_TRUE(contains(err, "2 pixels had linear values outside [0, 1] and were clamped")) << err;
    expect_spectra_in(img, 0.0f, 1.0f);
    // With --out-of-range keep the green is wider than Rec.709's: some samples go below 0.
    ExrImage kept =
        bake_ok(in, d / "kept.exr", {"--colorspace", "acescg", "--out-of-range", "keep"});
    float lo = 1.0f;
    for (const auto& [l, name] : spectral_channels(kept)) lo = std::min(lo, kept.at(name, 0, 0));
    EXPECT_LT(lo, 0.0f) << "ACEScg green kept should leave [0, 1]";
}

TEST(HardInputs, OtherWideGamutSpaces) {
    // The shipped config knows linear Rec.2020 and Display P3 textures; their saturated primaries
    // are outside Rec.709 and are counted as clamped.
    for (const char* cs : {"lin_rec2020", "display_p3_tx", "lin_p3d65", "aces2065_1"}) {
        ScratchDir d;
        const std::string in = d / (std::string(cs) + ".exr"), out = d / "out.exr";
        std::vector<float> px = {0.0f, 1.0f, 0.0f, 1.0f, 0.0f, 0.0f};
        write_image(in, 2, 1, 3, OIIO::TypeDesc::FLOAT, px.data());
        std::string err;
        ExrImage img = bake_ok(in, out, {"--colorspace", cs}, &err);
        EXPECT_TRUE(contains(err, "clamped")) << cs << ": " << err;
        expect_spectra_in(img, 0.0f, 1.0f);
    }
}

// A config's own arithmetic leaves [0, 1] by a few 1e-5: an sRGB texture read through a config
// written as ACES 1.x writes its Utility spaces (tests/ocio/aces1x_style.ocio: the 7-digit
// sRGB -> AP0 matrix, bridged back through the shipped config's AP0 -> Rec.709) gives white a green
// of 1 + 8.5e-5. Such pixels are clamped and counted (clamped_pixels, and clamped_excursion, the
// largest distance outside [0, 1], in the JSON record), not warned about: a warning on nearly every
// texture buries the real ones. Beyond the config's arithmetic (5e-4) it is a warning, with the
// largest excursion.
TEST(HardInputs, ClampsWithinTheConfigsArithmeticAreCountedNotWarned) {
    ScratchDir d;
    std::vector<unsigned char> px;  // every mix of 5 levels per channel: white and the primaries
    for (int r = 0; r < 5; ++r)
        for (int g = 0; g < 5; ++g)
            for (int b = 0; b < 5; ++b)
                for (int c : {r, g, b})
                    px.push_back(static_cast<unsigned char>(std::min(255, 64 * c)));
    write_image(d / "tex.png", 25, 5, 3, OIIO::TypeDesc::UINT8, px.data());
    const std::string config =
        std::string(SPECTEX_TEST_SOURCE_DIR) + "/tests/ocio/aces1x_style.ocio";
    RunResult r = run_spectex({"bake", d / "tex.png", "-o", d / "tex.exr", "--config", config,
                               "--method", "basis", "--json", d / "tex.jsonl"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(contains(r.err, "clamped")) << r.err;
    const nlohmann::json j = nlohmann::json::parse(read_file(d / "tex.jsonl"));
    EXPECT_EQ(j.value("colorspace", ""), "Utility - sRGB - Texture");
    EXPECT_GT(j.value("clamped_pixels", 0), 0) << j.dump();
    EXPECT_GT(j.value("clamped_excursion", -1.0), 0.0) << j.dump();
    EXPECT_LE(j.value("clamped_excursion", -1.0), 5e-4) << j.dump();
    EXPECT_TRUE(j.value("warnings", nlohmann::json::array()).empty()) << j.dump();
    // verify re-applies the bake's policies to the source and reports the same two figures.
    RunResult v = run_spectex(
        {"verify", d / "tex.exr", "--source", d / "tex.png", "--report-only", "--json", "-"});
    ASSERT_EQ(v.status, 0) << v.err;
    const nlohmann::json src = nlohmann::json::parse(v.out).value("source", nlohmann::json());
    EXPECT_EQ(src.value("clamped_pixels", -1), j.value("clamped_pixels", 0)) << v.out;
    EXPECT_EQ(src.value("clamped_excursion", -1.0), j.value("clamped_excursion", 0.0)) << v.out;

    // Beyond the config's arithmetic: counted, clamped and warned about, with the largest
    // excursion (1.0004 is within it: counted, not the largest).
    const std::vector<float> lin = {1.01f,   0.5f, 0.5f, -0.002f, 0.5f, 0.5f,
                                    1.0004f, 0.5f, 0.5f, 0.5f,    0.5f, 0.5f};
    write_image(d / "lin.exr", 4, 1, 3, OIIO::TypeDesc::FLOAT, lin.data());
    std::string err;
    bake_ok(d / "lin.exr", d / "lin_out.exr", {"--method", "basis"}, &err);
    EXPECT_TRUE(
        contains(err, "3 pixels had linear values outside [0, 1] and were clamped (by up to 0.01)"))
        << err;
}

TEST(HardInputs, UnknownFileColourSpaceFallsBackToFileRules) {
    // A PNG labelled with a colour space the config lacks bakes like an unlabelled PNG (file rules:
    // sRGB texture); an EXR so labelled bakes like an unlabelled EXR (linear Rec.709).
    ScratchDir d;
    auto px = noise8(6 * 4 * 3, 5);
    write_image(d / "plain.png", 6, 4, 3, OIIO::TypeDesc::UINT8, px.data());
    write_image(d / "odd.png", 6, 4, 3, OIIO::TypeDesc::UINT8, px.data(),
                {{"oiio:ColorSpace", "Martian Gamut 7"}});
    ExrImage a = bake_ok(d / "plain.png", d / "plain.exr");
    std::string err;
    ExrImage b = bake_ok(d / "odd.png", d / "odd.exr", {}, &err);
    std::string why;
    EXPECT_TRUE(same_pixels(a, b, &why)) << why;
    EXPECT_EQ(a.attr("spectex:inputColorSpace"), b.attr("spectex:inputColorSpace"));

    std::vector<float> f(6 * 4 * 3);
    for (size_t i = 0; i < f.size(); ++i) f[i] = static_cast<float>(px[i]) / 255.0f;
    write_image(d / "plain.exr", 6, 4, 3, OIIO::TypeDesc::FLOAT, f.data());
    write_image(d / "odd.exr", 6, 4, 3, OIIO::TypeDesc::FLOAT, f.data(),
                {{"oiio:ColorSpace", "Martian Gamut 7"}});
    ExrImage c = bake_ok(d / "plain.exr", d / "plain_out.exr");
    ExrImage e = bake_ok(d / "odd.exr", d / "odd_out.exr");
    EXPECT_TRUE(same_pixels(c, e, &why)) << why;
    EXPECT_EQ(c.attr("spectex:inputColorSpace"), e.attr("spectex:inputColorSpace"));
}

// --out-of-range keep with half output: values beyond 65504 (the largest half) would become
// infinities, so the file fails and suggests --type float; float stores them finite.
TEST(HardInputs, KeepRefusesValuesHalfCannotStore) {
    ScratchDir d;
    std::vector<float> px(8 * 8 * 3, 0.5f);
    px[10] = 1e38f;
    px[40] = -7e4f;
    write_image(d / "hdr.exr", 8, 8, 3, OIIO::TypeDesc::FLOAT, px.data());
    // Without --method: --out-of-range keep takes the basis, the one method defined outside [0, 1].
    RunResult r = run_spectex({"bake", d / "hdr.exr", "-o", d / "h.exr", "--out-of-range", "keep"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(has_text(r.err, "largest half value")) << r.err;
    EXPECT_TRUE(has_text(r.err, "--type float")) << r.err;
    EXPECT_FALSE(file_exists(d / "h.exr"));
    // Float stores them: every sample finite.
    RunResult f = run_spectex({"bake", d / "hdr.exr", "-o", d / "f.exr", "--out-of-range", "keep",
                               "--type", "float", "-q"});
    ASSERT_EQ(f.status, 0) << f.err;
    for (const auto& [name, plane] : read_exr(d / "f.exr").pixels)
        for (float v : plane) ASSERT_TRUE(std::isfinite(v)) << name;
    // Large values half can hold are kept, finite.
    std::vector<float> big(8 * 8 * 3, 60000.0f);
    write_image(d / "big.exr", 8, 8, 3, OIIO::TypeDesc::FLOAT, big.data());
    RunResult b =
        run_spectex({"bake", d / "big.exr", "-o", d / "b.exr", "--out-of-range", "keep", "-q"});
    ASSERT_EQ(b.status, 0) << b.err;
    size_t n = 0;
    for (const auto& [name, plane] : read_exr(d / "b.exr").pixels)
        for (float v : plane) {
            ASSERT_TRUE(std::isfinite(v)) << name;
            ++n;
        }
    EXPECT_GT(n, 0u);
}
