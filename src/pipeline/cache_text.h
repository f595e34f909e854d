#pragma once
// The words every cache entry is written in (pipeline/cached_answer.h keeps the entries): the key's
// hash over everything an answer depends on, texts as hex digits, numbers exactly (%a), and a
// reader that spoils the whole entry on the first word missing or malformed.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "base/fnv1a.h"
#include "spectral/spectrum.h"
#include "spectral/wavelength_grid.h"

namespace spectex::cache_text {

// The key's material: every part is added with its length, so no two sequences of parts hash
// alike by moving a boundary.
class KeyHash {
  public:
    void text(const std::string& s) {
        const uint64_t n = s.size();
        add(&n, sizeof n);
        add(s.data(), s.size());
    }
    void number(double v) { add(&v, sizeof v); }
    void values(const std::vector<double>& v) {
        const uint64_t n = v.size();
        add(&n, sizeof n);
        add(v.data(), v.size() * sizeof(double));
    }
    void spectrum(const Spectrum& s) {
        values(s.lambda);
        values(s.value);
    }
    void grid(const WavelengthGrid& g) {
        values(g.lambda);
        values(g.weight);
        text(g.uniform ? "uniform" : "list");
        number(g.step);
    }
    // Two FNV-1a 64 over the same bytes from different starts: 128 bits, so that two settings
    // never share an entry by chance.
    std::string hex() const {
        char buf[40];
        std::snprintf(buf, sizeof buf, "%016llx%016llx",
                      static_cast<unsigned long long>(a_.value()),
                      static_cast<unsigned long long>(b_.value()));
        return buf;
    }

  private:
    void add(const void* p, size_t n) {
        a_.add(p, n);
        b_.add(p, n);
    }
    Fnv1a64 a_;
    Fnv1a64 b_ = [] {
        Fnv1a64 h;
        h.add("spectex plan cache", 18);
        return h;
    }();
};

// Texts as hex digits ("x" first, so that an empty one is a word too): any byte survives.
inline std::string hex_text(const std::string& s) {
    static const char* digits = "0123456789abcdef";
    std::string o = "x";
    for (unsigned char c : s) {
        o += digits[c >> 4];
        o += digits[c & 15];
    }
    return o;
}

inline bool unhex_text(const std::string& w, std::string* out) {
    if (w.empty() || w[0] != 'x' || w.size() % 2 != 1) return false;
    auto nib = [](char c) {
        return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
    };
    std::string s;
    for (size_t i = 1; i < w.size(); i += 2) {
        const int hi = nib(w[i]), lo = nib(w[i + 1]);
        if (hi < 0 || lo < 0) return false;
        s += static_cast<char>(hi * 16 + lo);
    }
    *out = std::move(s);
    return true;
}

// Numbers exactly: hexadecimal floating point ("%a") reads back to the same double.
inline std::string exact(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%a", v);
    return buf;
}

// The words of an entry, read in order; any word missing or malformed spoils the whole entry.
class Words {
  public:
    explicit Words(const std::string& text) : in_(text) {}
    bool ok() const { return ok_; }
    std::string word() {
        std::string w;
        if (!(in_ >> w)) ok_ = false;
        return w;
    }
    void expect(const std::string& w) {
        if (word() != w) ok_ = false;
    }
    double number() {
        const std::string w = word();
        char* end = nullptr;
        const double v = ok_ ? std::strtod(w.c_str(), &end) : 0;
        if (!ok_ || w.empty() || *end != '\0' || !std::isfinite(v)) ok_ = false;
        return ok_ ? v : 0;
    }
    long long whole(long long lo, long long hi) {
        const double v = number();
        if (!ok_ || v != std::floor(v) || v < static_cast<double>(lo) ||
            v > static_cast<double>(hi)) {
            ok_ = false;
            return lo;
        }
        return static_cast<long long>(v);
    }
    bool flag() { return whole(0, 1) == 1; }
    std::string text() {
        std::string s;
        if (!unhex_text(word(), &s)) ok_ = false;
        return s;
    }
    bool at_end() {
        std::string w;
        return !(in_ >> w);
    }

  private:
    std::istringstream in_;
    bool ok_ = true;
};

}  // namespace spectex::cache_text
