// The spectex:rebuild* attributes a renderer rebuilds spectra with: the encodings are the
// standard ones (another language's base64 and zlib.crc32 read them), the table is the method's
// own, and a method or table that cannot be recorded writes nothing rather than half a record.
#include "io/rebuild_record.h"

#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <string>

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
    // zlib.crc32(b"a\nb\nc\nd\ne\n") = 0xfb638305 (Python's zlib, the reference the docs name).
    EXPECT_EQ(rebuild_checksum("a", "b", "c", "d", "e"), "crc32:fb638305");
    EXPECT_NE(rebuild_checksum("a", "b", "c", "d", "e"), rebuild_checksum("a", "b", "c", "d", "f"));
}

TEST(RebuildRecord, TheTableIsTheMethodsFloatsLittleEndianAndTheChecksumCoversIt) {
    RebuildTable t;
    t.rule = "lattice";
    t.axis = {0, 0.25, 1};
    t.table.assign(27 * 2, 0.5f);
    t.table[1] = 1.0f;
    const std::vector<double> to_rgb = {1, 2, 3, 4, 5, 6};
    const auto a = as_map(rebuild_attributes(t, to_rgb, "400 700"));
    ASSERT_EQ(a.size(), 5u);
    EXPECT_EQ(a.at(key::kRebuild), "lattice");
    EXPECT_EQ(a.at(key::kRebuildAxis), "0 0.25 1");
    EXPECT_EQ(a.at(key::kRebuildToRgb), "1 2 3 4 5 6");
    // 0.5f = 00 00 00 3f, 1.0f = 00 00 80 3f: "AAAAPwAAgD8..." starts the base64.
    EXPECT_EQ(a.at(key::kRebuildTable).substr(0, 12), "AAAAPwAAgD8A");
    EXPECT_EQ(a.at(key::kRebuildTable).size(), (27 * 2 * 4 + 2) / 3 * 4);
    EXPECT_EQ(a.at(key::kRebuildChecksum), rebuild_checksum("lattice", "0 0.25 1", "1 2 3 4 5 6",
                                                            a.at(key::kRebuildTable), "400 700"));
}

TEST(RebuildRecord, NothingIsWrittenWithoutARuleOrOverTheLimit) {
    const std::vector<double> to_rgb(3, 1.0);
    RebuildTable none;  // Jakob-Hanika's: no rule
    none.table.assign(10, 0.5f);
    EXPECT_TRUE(rebuild_attributes(none, to_rgb, "500").empty());
    RebuildTable big;
    big.rule = "basis";
    big.table.assign(kRebuildTableLimit + 1, 0.5f);
    EXPECT_TRUE(rebuild_attributes(big, to_rgb, "500").empty());
    big.table.resize(kRebuildTableLimit);
    const auto a = as_map(rebuild_attributes(big, to_rgb, "500"));
    EXPECT_EQ(a.count(key::kRebuildAxis), 0u) << "the basis has no breakpoints";
    EXPECT_EQ(a.count(key::kRebuildTable), 1u);
}

}  // namespace
}  // namespace spectex
