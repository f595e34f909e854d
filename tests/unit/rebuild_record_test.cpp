// The spectex:rebuild* attributes a renderer rebuilds spectra with: the encodings are the
// standard ones (another language's base64, zlib and zlib.crc32 read them), the table is the
// method's own in the file's type, and a method or table that cannot be recorded writes nothing
// rather than half a record.
#include "io/rebuild_record.h"

#include <gtest/gtest.h>
#include <libdeflate.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <string>

#include "base/half.h"
#include "io/provenance_keys.h"

namespace spectex {
namespace {

namespace key = provenance_key;

std::map<std::string, std::string> as_map(
    const std::vector<std::pair<std::string, std::string>>& a) {
    return {a.begin(), a.end()};
}

TEST(RebuildRecord, Base64IsRfc4648WithPadding) {
    // RFC 4648, section 10.
    const std::pair<const char*, const char*> vectors[] = {{"", ""},
                                                           {"f", "Zg=="},
                                                           {"fo", "Zm8="},
                                                           {"foo", "Zm9v"},
                                                           {"foob", "Zm9vYg=="},
                                                           {"fooba", "Zm9vYmE="},
                                                           {"foobar", "Zm9vYmFy"}};
    for (const auto& [in, out] : vectors) EXPECT_EQ(base64_encode(in, std::strlen(in)), out) << in;
    const unsigned char high[] = {0xfb, 0xff, 0xbf};  // the two last digits, '+' and '/'
    EXPECT_EQ(base64_encode(high, 3), "+/+/");
}

TEST(RebuildRecord, ChecksumIsZlibsCrc32OfTheTextsEachEndedByALineFeed) {
    // zlib.crc32(b"a\nb\nc\nd\ne\nf\n") = 0x9b6dea7c (Python's zlib, the reference the docs name).
    EXPECT_EQ(rebuild_checksum("a", "b", "c", "d", "e", "f"), "crc32:9b6dea7c");
    EXPECT_NE(rebuild_checksum("a", "b", "c", "d", "e", "f"),
              rebuild_checksum("a", "b", "c", "d", "e", "g"));
}

// The encoded table undone as a reader does: inflate, planes back to values, sums along each row.
std::vector<uint32_t> decode(const std::string& z, size_t n, size_t row, size_t size) {
    std::string planes(n * size, '\0');
    libdeflate_decompressor* d = libdeflate_alloc_decompressor();
    size_t got = 0;
    const auto r =
        libdeflate_zlib_decompress(d, z.data(), z.size(), planes.data(), planes.size(), &got);
    libdeflate_free_decompressor(d);
    EXPECT_EQ(r, LIBDEFLATE_SUCCESS);
    EXPECT_EQ(got, planes.size());
    const uint32_t mask = size == 2 ? 0xffffu : 0xffffffffu;
    std::vector<uint32_t> v(n);
    for (size_t i = 0; i < n; ++i) {
        uint32_t x = 0;
        for (size_t b = 0; b < size; ++b) x |= uint32_t(uint8_t(planes[b * n + i])) << (8 * b);
        v[i] = (i % row ? v[i - 1] + x : x) & mask;
    }
    return v;
}

TEST(RebuildRecord, TheTableIsTheMethodsValuesInTheFilesTypeDifferencedInPlanesAndDeflated) {
    // Two rows of five: a rising and a falling one (differences that wrap around zero), values a
    // half cannot hold exactly (it rounds them to nearest, as the file's samples are).
    const std::vector<float> t = {0.1f, 0.2f, 0.3f, 0.7f, 1.0f, 0.9f, 0.5f, 0.25f, 0.01f, 0.0f};
    const auto h = decode(encode_rebuild_table(t, 5, true), t.size(), 5, 2);
    const auto f = decode(encode_rebuild_table(t, 5, false), t.size(), 5, 4);
    for (size_t i = 0; i < t.size(); ++i) {
        EXPECT_EQ(h[i], float_to_half(t[i])) << i;
        uint32_t u;
        std::memcpy(&u, &t[i], 4);
        EXPECT_EQ(f[i], u) << i;
    }
    // Without the differences the planes of a smooth table would not shrink like this: the
    // default's 9^3 x 31 lattice fits in 33 KB of base64 (checked on a bake in the Python tests).
}

TEST(RebuildRecord, TheAttributesNameTheEncodingAndTheChecksumCoversItAll) {
    RebuildTable t;
    t.rule = "lattice";
    t.axis = {0, 0.25, 1};
    t.table.assign(27 * 2, 0.5f);
    t.table[1] = 1.0f;
    const std::vector<double> to_rgb = {1, 2, 3, 4, 5, 6};
    for (const bool half : {true, false}) {
        const auto a = as_map(rebuild_attributes(t, to_rgb, "400 700", half));
        ASSERT_EQ(a.size(), 6u);
        EXPECT_EQ(a.at(key::kRebuild), "lattice");
        EXPECT_EQ(a.at(key::kRebuildAxis), "0 0.25 1");
        EXPECT_EQ(a.at(key::kRebuildToRgb), "1 2 3 4 5 6");
        EXPECT_EQ(a.at(key::kRebuildTableEncoding), half ? "half-delta-zlib" : "float-delta-zlib");
        const std::string z = encode_rebuild_table(t.table, 2, half);
        EXPECT_EQ(a.at(key::kRebuildTable), base64_encode(z.data(), z.size()));
        EXPECT_EQ(a.at(key::kRebuildChecksum),
                  rebuild_checksum("lattice", "0 0.25 1", "1 2 3 4 5 6", a.at(key::kRebuildTable),
                                   "400 700", a.at(key::kRebuildTableEncoding)));
    }
}

TEST(RebuildRecord, NothingIsWrittenWithoutARuleOrOverTheLimit) {
    const std::vector<double> to_rgb(3, 1.0);
    RebuildTable none;  // Jakob-Hanika's: no rule
    none.table.assign(10, 0.5f);
    EXPECT_TRUE(rebuild_attributes(none, to_rgb, "500", true).empty());
    RebuildTable big;
    big.rule = "basis";
    big.table.assign(kRebuildTableLimit + 1, 0.5f);
    EXPECT_TRUE(rebuild_attributes(big, to_rgb, "500", true).empty());
    big.table.resize(kRebuildTableLimit);
    const auto a = as_map(rebuild_attributes(big, to_rgb, "500", true));
    EXPECT_EQ(a.count(key::kRebuildAxis), 0u) << "the basis has no breakpoints";
    EXPECT_EQ(a.count(key::kRebuildTable), 1u);
}

}  // namespace
}  // namespace spectex
