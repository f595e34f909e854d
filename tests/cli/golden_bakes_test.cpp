// Refactoring guard: a fixed set of bakes must give the same bytes before and after a
// behaviour-preserving change. tests/cli/golden_bakes.txt holds one hash per bake; a change that
// alters any output byte fails here, naming the bake.
//
// What is hashed, with a reader that shares no code with spectex (a minimal parse of the OpenEXR
// header as the file format document lays it out):
//   - every header attribute's name, type and value bytes, except the few that record where and
//     when the bake ran (kLocal below: paths, times, the command line, the tool's version, the
//     settings hash that mixes both in, and the source's bytes, which OpenImageIO's encoder writes
//     as it likes);
//   - every byte from the first chunk to the end of the file: all chunks, compressed as written.
// The offset table is left out only because its values move with the header's length (a path).
//
// After an intended change of output (a new attribute, another rounding), regenerate the list with
//   SPECTEX_GOLDEN_UPDATE=1 build/tests/spectex_cli_tests --gtest_filter='GoldenBakes.*'
// and say in the commit why the bytes changed.
#include <gtest/gtest.h>
#include <sys/time.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;

namespace {

// spectex:settingsHash is left out too: it hashes the tool's version with the settings
// (pipeline/batch_files.cpp), so another version gives another; the settings themselves are in the
// attributes that are hashed (the colour config by what it does, spectex:colorTransform).
const std::set<std::string> kLocal = {
    "spectex:source",       "spectex:commandLine",    "spectex:config",
    "spectex:version",      "spectex:sourceAbsolute", "spectex:sourceFromOutput",
    "spectex:sourceSize",   "spectex:sourceMtime",    "spectex:sourceHash",
    "spectex:settingsHash",
};

uint64_t fnv1a(uint64_t h, const char* p, size_t n) {
    for (size_t i = 0; i < n; ++i) {
        h ^= static_cast<unsigned char>(p[i]);
        h *= 1099511628211ull;
    }
    return h;
}

struct Parsed {
    bool ok = false;
    std::string why;
    uint64_t hash = 1469598103934665603ull;
    std::vector<std::string> attributes;  // names, for the test's own checks
};

// Single-part OpenEXR: magic, version, attributes (name\0 type\0 int32 size, value) up to an empty
// name, then the offset table (uint64 each, ascending for the writers spectex uses), then chunks.
Parsed hash_exr(const std::string& bytes) {
    Parsed r;
    auto fail = [&](const std::string& why) {
        r.why = why;
        return r;
    };
    if (bytes.size() < 8 || std::memcmp(bytes.data(), "\x76\x2f\x31\x01", 4) != 0)
        return fail("not OpenEXR");
    size_t p = 8;
    auto cstr = [&](std::string& out) {
        const size_t z = bytes.find('\0', p);
        if (z == std::string::npos) return false;
        out = bytes.substr(p, z - p);
        p = z + 1;
        return true;
    };
    for (;;) {
        std::string name, type;
        if (!cstr(name)) return fail("header runs past the end");
        if (name.empty()) break;
        if (!cstr(type) || p + 4 > bytes.size())
            return fail("attribute " + name + " runs past the end");
        int32_t size = 0;
        std::memcpy(&size, bytes.data() + p, 4);
        p += 4;
        if (size < 0 || p + static_cast<size_t>(size) > bytes.size())
            return fail("attribute " + name + " has a bad size");
        r.attributes.push_back(name);
        if (!kLocal.count(name)) {
            r.hash = fnv1a(r.hash, name.c_str(), name.size() + 1);
            r.hash = fnv1a(r.hash, type.c_str(), type.size() + 1);
            r.hash = fnv1a(r.hash, bytes.data() + p, static_cast<size_t>(size));
        }
        p += static_cast<size_t>(size);
    }
    if (p + 8 > bytes.size()) return fail("no offset table");
    uint64_t first = 0;
    std::memcpy(&first, bytes.data() + p, 8);
    // The table runs from p to the first chunk; every entry must point past it, inside the file.
    if (first <= p || first >= bytes.size() || (first - p) % 8 != 0)
        return fail("bad first offset");
    for (size_t e = p; e < first; e += 8) {
        uint64_t off = 0;
        std::memcpy(&off, bytes.data() + e, 8);
        if (off < first || off >= bytes.size()) return fail("offset outside the chunks");
    }
    r.hash = fnv1a(r.hash, bytes.data() + first, bytes.size() - static_cast<size_t>(first));
    r.ok = true;
    return r;
}

std::string hex(uint64_t h) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
    return buf;
}

std::string list_path() {
    return std::string(SPECTEX_TEST_SOURCE_DIR) + "/tests/cli/golden_bakes.txt";
}

std::map<std::string, std::string> read_list() {
    std::map<std::string, std::string> m;
    std::ifstream in(list_path());
    for (std::string line; std::getline(in, line);) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ls(line);
        std::string name, h;
        if (ls >> name >> h) m[name] = h;
    }
    return m;
}

// Inputs whose decoded pixels are fixed: a ramp over all codes with every channel different.
void make_inputs(const ScratchDir& d) {
    const int w = 61, h = 37;
    std::vector<uint8_t> p8(w * h * 3), p8a(w * h * 4);
    std::vector<uint16_t> p16(w * h * 3);
    std::vector<float> pf(w * h * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const size_t i = static_cast<size_t>(y * w + x);
            for (int c = 0; c < 3; ++c) {
                const uint32_t v =
                    (static_cast<uint32_t>(x) * 37u + static_cast<uint32_t>(y) * 101u +
                     static_cast<uint32_t>(c) * 71u) *
                    2654435761u;
                p8[i * 3 + c] = static_cast<uint8_t>(v >> 24);
                p8a[i * 4 + c] = static_cast<uint8_t>(v >> 24);
                p16[i * 3 + c] = static_cast<uint16_t>(v >> 16);
                // Scene-linear floats with values above 1 and below 0 (out-of-range handling).
                pf[i * 3 + c] = static_cast<float>(static_cast<int32_t>(v >> 20) - 256) / 1500.0f;
            }
            p8a[i * 4 + 3] = static_cast<uint8_t>((x * 255) / (w - 1));
        }
    write_image(d / "rgb8.png", w, h, 3, OIIO::TypeDesc::UINT8, p8.data());
    write_image(d / "rgba8.png", w, h, 4, OIIO::TypeDesc::UINT8, p8a.data());
    write_image(d / "rgb16.tif", w, h, 3, OIIO::TypeDesc::UINT16, p16.data());
    write_image(d / "linear.exr", w, h, 3, OIIO::TypeDesc::FLOAT, pf.data());
    std::ofstream(d / "grid.txt") << "400\n430\n455\n480\n520\n560\n590\n610\n640\n700\n";
}

struct Bake {
    std::string name;
    std::string input;
    std::vector<std::string> options;
};

std::vector<Bake> bakes() {
    return {
        // The default bake: neither --method nor an option of one method (the LHTSS lattice, its
        // precision budget under six lights, deflate level 1; the bits chosen with no cache).
        {"png8-default", "rgb8.png", {"--no-cache"}},
        // The seed's default, one option away, and the options below on it.
        {"png8-basis", "rgb8.png", {"--method", "basis"}},
        {"png8-float", "rgb8.png", {"--method", "basis", "--type", "float"}},
        {"png8-none", "rgb8.png", {"--method", "basis", "--compression", "none"}},
        {"png8-zips-level1",
         "rgb8.png",
         {"--method", "basis", "--compression", "zips", "--zip-level", "1"}},
        {"png8-piz", "rgb8.png", {"--method", "basis", "--compression", "piz"}},
        {"png8-400-700-10-preview",
         "rgb8.png",
         {"--method", "basis", "--wavelengths", "400:700:10", "--preview"}},
        {"png8-nearest-rounding", "rgb8.png", {"--method", "basis", "--half-rounding", "nearest"}},
        {"png8-tiled-mipmap", "rgb8.png", {"--method", "basis", "--tile", "16", "--mipmap"}},
        {"png8-norm-d50",
         "rgb8.png",
         {"--objective", "norm", "--illuminant", "D50", "--wavelengths", "400:700:10"}},
        {"png8-1964-allow-infeasible",
         "rgb8.png",
         {"--observer", "cie1964-10", "--wavelengths", "400:700:10", "--allow-infeasible"}},
        {"png8-nonuniform-file",
         "rgb8.png",
         {"--method", "basis", "--wavelengths-file", "@grid.txt"}},
        {"png8-lattice",
         "rgb8.png",
         {"--method", "lattice", "--lattice-size", "5", "--wavelengths", "400:700:10"}},
        {"png8-jakob-hanika",
         "rgb8.png",
         {"--method", "jakob-hanika", "--jh-resolution", "9", "--wavelengths", "400:700:10"}},
        // The precision budget's coarse-grid rounding (its vectorised path is checked against
        // these bytes, which the scalar one made); the chooser's bits come from no cache.
        {"png8-precision-auto",
         "rgb8.png",
         {"--method", "basis", "--precision", "auto", "--lights", "D65,A,FL11", "--max-de", "0.5",
          "--wavelengths", "400:700:10", "--no-cache"}},
        {"png8-lattice-precision-auto",
         "rgb8.png",
         {"--method", "lattice", "--lattice-size", "5", "--vertex-prior", "lhtss", "--precision",
          "auto", "--lights", "D65,A,FL2,FL11", "--max-de", "0.5", "--wavelengths", "400:700:10",
          "--no-cache"}},
        {"rgba8-associated", "rgba8.png", {"--method", "basis"}},
        {"rgba8-unassociated", "rgba8.png", {"--method", "basis", "--alpha", "unassociated"}},
        {"tif16-basis", "rgb16.tif", {"--method", "basis"}},
        {"exr-keep",
         "linear.exr",
         {"--method", "basis", "--out-of-range", "keep", "--type", "float"}},
        {"exr-clamp", "linear.exr", {"--method", "basis"}},
    };
}

}  // namespace

TEST(GoldenBakes, TheHashReaderSeesHeaderAndChunks) {
    ScratchDir d;
    make_inputs(d);
    ASSERT_EQ(run_spectex({"bake", d / "rgb8.png", "-o", d / "a.exr"}).status, 0);
    std::string bytes = read_file(d / "a.exr");
    const Parsed a = hash_exr(bytes);
    ASSERT_TRUE(a.ok) << a.why;
    // The reader found the attributes a spectral EXR must have (so it parsed the header right).
    for (const char* n :
         {"channels", "compression", "dataWindow", "spectralLayoutVersion", "spectex:settingsHash"})
        EXPECT_NE(std::find(a.attributes.begin(), a.attributes.end(), n), a.attributes.end()) << n;
    // A flipped byte in the last chunk changes the hash; so does a changed kept attribute.
    std::string flipped = bytes;
    flipped[flipped.size() - 1] ^= 1;
    EXPECT_NE(hash_exr(flipped).hash, a.hash);
    const size_t at = bytes.find("spectralLayoutVersion");
    ASSERT_NE(at, std::string::npos);
    std::string renamed = bytes;
    renamed[at] = 'S';
    EXPECT_NE(hash_exr(renamed).hash, a.hash);
    // The same bake from another folder, under another name, an hour later: the same hash.
    ScratchDir e;
    make_inputs(e);
    struct timeval times[2] = {{1000000000, 0}, {1000000000, 0}};
    ASSERT_EQ(::utimes((e / "rgb8.png").c_str(), times), 0);
    ASSERT_EQ(run_spectex({"bake", e / "rgb8.png", "-o", e / "other-name.exr"}).status, 0);
    EXPECT_EQ(hash_exr(read_file(e / "other-name.exr")).hash, a.hash);
}

TEST(GoldenBakesSlow, FixedBakesGiveTheCommittedBytes) {
    ScratchDir d;
    make_inputs(d);
    const bool update = std::getenv("SPECTEX_GOLDEN_UPDATE") != nullptr;
    const std::map<std::string, std::string> want = read_list();
    if (!update) ASSERT_FALSE(want.empty()) << list_path() << " is missing or empty";
    std::ostringstream out;
    out << "# Hashes of the bakes in tests/cli/golden_bakes_test.cpp (header minus where/when, and "
           "all\n"
           "# chunks). Regenerate only for an intended change of output: "
           "SPECTEX_GOLDEN_UPDATE=1.\n";
    for (const Bake& b : bakes()) {
        std::vector<std::string> args = {"bake", d / b.input, "-o", d / (b.name + ".exr")};
        for (const std::string& o : b.options)
            args.push_back(o[0] == '@' ? d / o.substr(1) : o);  // @name: a file in d
        const RunResult r = run_spectex(args);
        ASSERT_EQ(r.status, 0) << b.name << ": " << r.err;
        const Parsed p = hash_exr(read_file(d / (b.name + ".exr")));
        ASSERT_TRUE(p.ok) << b.name << ": " << p.why;
        out << b.name << " " << hex(p.hash) << "\n";
        if (update) continue;
        const auto it = want.find(b.name);
        ASSERT_NE(it, want.end()) << b.name << " is not in " << list_path();
        EXPECT_EQ(hex(p.hash), it->second)
            << b.name << ": the output bytes changed (" << r.err << ")";
    }
    if (update)
        std::ofstream(list_path()) << out.str();
    else
        EXPECT_EQ(want.size(), bakes().size())
            << list_path() << " lists bakes the test no longer makes";
}
