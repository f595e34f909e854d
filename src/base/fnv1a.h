#pragma once
// FNV-1a, 64 bits: the one hash spectex writes into headers ("fnv1a64:<16 hex digits>"): settings,
// configs, bases, and the bytes of a bake's source file (spectex:sourceHash). Not cryptographic: it
// tells a changed file from an unchanged one, it does not resist someone forging a collision.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace spectex {

class Fnv1a64 {
  public:
    static constexpr uint64_t kOffset = 0xcbf29ce484222325ull;
    static constexpr uint64_t kPrime = 0x100000001b3ull;

    void add(const void* data, size_t n) {
        const unsigned char* p = static_cast<const unsigned char*>(data);
        uint64_t h = h_;
        for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * kPrime;
        h_ = h;
    }
    uint64_t value() const { return h_; }
    // "fnv1a64:<16 lowercase hex digits>"
    std::string text() const { return text(h_); }
    static std::string text(uint64_t h) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "fnv1a64:%016llx", static_cast<unsigned long long>(h));
        return buf;
    }

  private:
    uint64_t h_ = kOffset;
};

}  // namespace spectex
