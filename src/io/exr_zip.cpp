#include "io/exr_zip.h"

#include <libdeflate.h>

#include "base/error.h"

namespace spectex {

void zip_prepare(const uint8_t* in, size_t n, uint8_t* out) {
    uint8_t* t1 = out;
    uint8_t* t2 = out + (n + 1) / 2;
    size_t i = 0;
    for (; i + 1 < n; i += 2) {
        *t1++ = in[i];
        *t2++ = in[i + 1];
    }
    if (i < n) *t1++ = in[i];
    int p = n ? out[0] : 0;
    for (size_t j = 1; j < n; ++j) {
        const int v = out[j];
        out[j] = static_cast<uint8_t>(v - p + (128 + 256));
        p = v;
    }
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
