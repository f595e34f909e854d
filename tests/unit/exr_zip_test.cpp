// io/exr_zip: OpenEXR's ZIP block as written by the core writer. The file-level tests
// (exr_writer_test, the golden bakes) read whole files back through OpenEXR; these pin the block
// rules: the pre-pass is inverted exactly, a block deflate cannot shrink is stored raw and
// unchanged, and a stored compressed block inflates and un-prepares to the samples.
#include "io/exr_zip.h"

#include <gtest/gtest.h>
#include <libdeflate.h>

#include <random>
#include <vector>

namespace spectex {
namespace {

TEST(ExrZip, ThePrePassIsInvertedForEverySize) {
    std::mt19937 rng(7);
    for (size_t n : {0, 1, 2, 3, 4, 5, 64, 1001}) {
        std::vector<uint8_t> in(n), prepared(n), back(n);
        for (auto& b : in) b = static_cast<uint8_t>(rng());
        zip_prepare(in.data(), n, prepared.data());
        zip_restore(prepared.data(), n, back.data());
        EXPECT_EQ(back, in) << n << " bytes";
    }
}

TEST(ExrZip, ThePrePassIsOpenExrsByteForByte) {
    // OpenEXR's definition, one byte at a time: even bytes then odd ones, then each byte minus the
    // one before it plus 128. Sizes around the vector loops' 16- and 32-byte steps.
    std::mt19937 rng(13);
    for (size_t n = 0; n < 200; ++n) {
        std::vector<uint8_t> in(n), got(n), want(n);
        for (auto& b : in) b = static_cast<uint8_t>(rng());
        size_t k = 0;
        for (size_t i = 0; i < n; i += 2) want[k++] = in[i];
        for (size_t i = 1; i < n; i += 2) want[k++] = in[i];
        for (size_t j = n; j-- > 1;) want[j] = static_cast<uint8_t>(want[j] - want[j - 1] + 128);
        zip_prepare(in.data(), n, got.data());
        EXPECT_EQ(got, want) << n << " bytes";
    }
}

TEST(ExrZip, ABlockDeflateCannotShrinkIsStoredRawAndUnchanged) {
    DeflaterPool pool(4, "t.exr");
    std::mt19937 rng(11);
    std::vector<uint8_t> block(4096);
    for (auto& b : block) b = static_cast<uint8_t>(rng());
    const std::vector<uint8_t> before = block;
    bool raw = false;
    EXPECT_EQ(pool.compress(block.data(), block.size(), &raw), block.size());
    EXPECT_TRUE(raw);
    EXPECT_EQ(block, before);
    // One byte cannot be stored in fewer: raw too.
    uint8_t one = 42;
    EXPECT_EQ(pool.compress(&one, 1, &raw), 1u);
    EXPECT_TRUE(raw);
    EXPECT_EQ(one, 42);
}

TEST(ExrZip, ACompressedBlockInflatesToTheSamples) {
    DeflaterPool pool(6, "t.exr");
    std::vector<uint8_t> samples(8192);
    for (size_t i = 0; i < samples.size(); ++i) samples[i] = static_cast<uint8_t>((i / 2) % 7);
    std::vector<uint8_t> block = samples;
    bool raw = true;
    const size_t bytes = pool.compress(block.data(), block.size(), &raw);
    EXPECT_FALSE(raw);
    ASSERT_LT(bytes, samples.size());
    libdeflate_decompressor* d = libdeflate_alloc_decompressor();
    ASSERT_NE(d, nullptr);
    std::vector<uint8_t> prepared(samples.size()), back(samples.size());
    size_t got = 0;
    EXPECT_EQ(
        libdeflate_zlib_decompress(d, block.data(), bytes, prepared.data(), prepared.size(), &got),
        LIBDEFLATE_SUCCESS);
    libdeflate_free_decompressor(d);
    ASSERT_EQ(got, samples.size());
    zip_restore(prepared.data(), got, back.data());
    EXPECT_EQ(back, samples);
}

}  // namespace
}  // namespace spectex
