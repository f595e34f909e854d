#include "io/exr_zip.h"

#include <libdeflate.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "base/error.h"

namespace spectex {

void zip_prepare(const uint8_t* in, size_t n, uint8_t* out) {
    // OpenEXR's ZIP predictor: the even bytes, then the odd ones, each byte then replaced by its
    // difference from the one before it plus 128. Sixteen bytes at a time with SSE2 (every x86-64
    // has it), the same bytes as the scalar loops.
    uint8_t* t1 = out;
    uint8_t* t2 = out + (n + 1) / 2;
    size_t i = 0;
#if defined(__SSE2__)
    const __m128i low = _mm_set1_epi16(0x00ff);
    for (; i + 32 <= n; i += 32) {
        const __m128i a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + i));
        const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in + i + 16));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(t1),
                         _mm_packus_epi16(_mm_and_si128(a, low), _mm_and_si128(b, low)));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(t2),
                         _mm_packus_epi16(_mm_srli_epi16(a, 8), _mm_srli_epi16(b, 8)));
        t1 += 16;
        t2 += 16;
    }
#endif
    for (; i + 1 < n; i += 2) {
        *t1++ = in[i];
        *t2++ = in[i + 1];
    }
    if (i < n) *t1++ = in[i];
    // The differences from the end backwards: each byte's predecessor is still unchanged when it
    // is read.
    size_t j = n;
#if defined(__SSE2__)
    const __m128i bias = _mm_set1_epi8(static_cast<char>(128));
    for (; j >= 17; j -= 16) {
        const __m128i cur = _mm_loadu_si128(reinterpret_cast<const __m128i*>(out + j - 16));
        const __m128i prev = _mm_loadu_si128(reinterpret_cast<const __m128i*>(out + j - 17));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(out + j - 16),
                         _mm_add_epi8(_mm_sub_epi8(cur, prev), bias));
    }
#endif
    for (; j >= 2; --j) out[j - 1] = static_cast<uint8_t>(out[j - 1] - out[j - 2] + 128);
}

void zip_restore(uint8_t* prepared, size_t n, uint8_t* out) {
    for (size_t j = 1; j < n; ++j)
        prepared[j] = static_cast<uint8_t>(prepared[j - 1] + prepared[j] - 128);
    const uint8_t* t1 = prepared;
    const uint8_t* t2 = prepared + (n + 1) / 2;
    for (size_t i = 0; i < n; ++i) out[i] = (i % 2 == 0) ? *t1++ : *t2++;
}

// A deflate compressor and its scratch block.
struct DeflaterPool::Deflater {
    libdeflate_compressor* z = nullptr;
    std::vector<uint8_t> scratch;
    ~Deflater() {
        if (z) libdeflate_free_compressor(z);
    }
};

DeflaterPool::DeflaterPool(int level, std::string name) : level_(level), name_(std::move(name)) {}

DeflaterPool::~DeflaterPool() = default;

std::unique_ptr<DeflaterPool::Deflater> DeflaterPool::take() {
    {
        std::lock_guard<std::mutex> lock(mu_);
        if (!idle_.empty()) {
            std::unique_ptr<Deflater> d = std::move(idle_.back());
            idle_.pop_back();
            return d;
        }
    }
    auto d = std::make_unique<Deflater>();
    d->z = libdeflate_alloc_compressor(level_);
    if (!d->z) throw Error(name_ + ": cannot allocate a deflate compressor");
    return d;
}

void DeflaterPool::give(std::unique_ptr<Deflater> d) {
    std::lock_guard<std::mutex> lock(mu_);
    idle_.push_back(std::move(d));
}

size_t DeflaterPool::compress(uint8_t* block, size_t n, bool* stored_raw) {
    std::unique_ptr<Deflater> d = take();
    std::vector<uint8_t>& scratch = d->scratch;
    if (scratch.size() < n) scratch.resize(n);
    zip_prepare(block, n, scratch.data());
    // A block is stored compressed only if that makes it smaller, so the output may use at most
    // n - 1 bytes.
    size_t out = n > 1 ? libdeflate_zlib_compress(d->z, scratch.data(), n, block, n - 1) : 0;
    *stored_raw = out == 0;
    if (out == 0) {
        zip_restore(scratch.data(), n, block);
        out = n;
    }
    give(std::move(d));
    return out;
}

}  // namespace spectex
