#pragma once
// Helpers for end-to-end tests that check spectex's output independently of spectex's own code:
// read an OpenEXR file with OpenEXR's C++ API (every channel converted to float by OpenEXR), read
// the shipped basis CSV with a tiny parser, and the IEC 61966-2-1 sRGB decoding formula.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace spectex_test {

struct ExrImage {
    Imf::Header header;
    Imath::Box2i data_window, display_window;
    int width = 0, height = 0;
    std::vector<std::string> channel_names;  // in the file's (alphabetical) order
    std::map<std::string, Imf::PixelType> types;
    std::map<std::string, std::vector<float>> pixels;  // width*height, rows of the data window

    bool has(const std::string& c) const { return types.count(c) != 0; }
    // x, y relative to the data window's origin.
    float at(const std::string& c, int x, int y) const {
        return pixels.at(
            c)[static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)];
    }
    // A string attribute's value; "" when absent or not a string.
    std::string attr(const std::string& name) const {
        const auto* a = header.findTypedAttribute<Imf::StringAttribute>(name);
        return a ? a->value() : std::string();
    }
    bool has_attr(const std::string& name) const {
        return header.findTypedAttribute<Imf::StringAttribute>(name) != nullptr;
    }
};

// Reads every channel of an OpenEXR file as FLOAT (OpenEXR converts half exactly).
inline ExrImage read_exr(const std::string& path) {
    Imf::InputFile in(path.c_str());
    ExrImage img;
    img.header = in.header();
    img.data_window = in.header().dataWindow();
    img.display_window = in.header().displayWindow();
    const Imath::Box2i& dw = img.data_window;
    img.width = dw.max.x - dw.min.x + 1;
    img.height = dw.max.y - dw.min.y + 1;
    const size_t n = static_cast<size_t>(img.width) * static_cast<size_t>(img.height);
    Imf::FrameBuffer fb;
    for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it) {
        std::string name = it.name();
        img.channel_names.push_back(name);
        img.types[name] = it.channel().type;
        auto& v = img.pixels[name];
        v.assign(n, -12345.0f);
        char* base = reinterpret_cast<char*>(v.data()) -
                     (static_cast<ptrdiff_t>(dw.min.y) * img.width + dw.min.x) *
                         static_cast<ptrdiff_t>(sizeof(float));
        fb.insert(name, Imf::Slice(Imf::FLOAT, base, sizeof(float),
                                   sizeof(float) * static_cast<size_t>(img.width)));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    return img;
}

// "T.<λ>nm" (dot or comma decimal separator, Fichet 2021) -> λ; false when not a reflective
// channel.
inline bool parse_t_channel(const std::string& name, double* lambda) {
    if (name.size() < 5 || name.compare(0, 2, "T.") != 0 ||
        name.compare(name.size() - 2, 2, "nm") != 0)
        return false;
    std::string num = name.substr(2, name.size() - 4);
    for (char& c : num)
        if (c == ',') c = '.';
    char* end = nullptr;
    double v = std::strtod(num.c_str(), &end);
    if (num.empty() || *end != '\0') return false;
    *lambda = v;
    return true;
}

// The spectral channels of an image, sorted by wavelength.
inline std::vector<std::pair<double, std::string>> spectral_channels(const ExrImage& img) {
    std::vector<std::pair<double, std::string>> v;
    for (const auto& n : img.channel_names) {
        double l;
        if (parse_t_channel(n, &l)) v.emplace_back(l, n);
    }
    std::sort(v.begin(), v.end());
    return v;
}

struct TestBasis {
    std::vector<double> lambda, r, g, b;
};

// config/spectral/basis_<name>.csv: '#' comments, a header line, then "wavelength,r,g,b" rows.
inline TestBasis read_test_basis(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot open " + path);
    TestBasis t;
    std::string line;
    bool header = false;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        if (!header) {
            header = true;
            continue;
        }
        std::stringstream ss(line);
        std::string f[4];
        for (auto& s : f) std::getline(ss, s, ',');
        t.lambda.push_back(std::strtod(f[0].c_str(), nullptr));
        t.r.push_back(std::strtod(f[1].c_str(), nullptr));
        t.g.push_back(std::strtod(f[2].c_str(), nullptr));
        t.b.push_back(std::strtod(f[3].c_str(), nullptr));
    }
    return t;
}

inline const TestBasis& mallett_basis() {
    static const TestBasis b =
        read_test_basis(std::string(SPECTEX_TEST_DATA_DIR) + "/spectral/basis_mallett2019.csv");
    return b;
}

// IEC 61966-2-1 sRGB decoding, in double.
inline double srgb_to_linear(double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// Expected spectrum of linear Rec.709 (r, g, b) under the basis, in double.
inline std::vector<double> expected_spectrum(double r, double g, double b,
                                             const TestBasis& basis = mallett_basis()) {
    std::vector<double> s(basis.lambda.size());
    for (size_t k = 0; k < s.size(); ++k) s[k] = r * basis.r[k] + g * basis.g[k] + b * basis.b[k];
    return s;
}

// FNV-1a 64 over the little-endian IEEE bytes of lambda, r, g, b (spectex:basisChecksum's
// definition).
inline std::string basis_fnv1a64(const TestBasis& t) {
    uint64_t h = 0xcbf29ce484222325ull;
    for (const auto* v : {&t.lambda, &t.r, &t.g, &t.b})
        for (double d : *v) {
            uint64_t bits;
            std::memcpy(&bits, &d, sizeof bits);
            for (int i = 0; i < 8; ++i) {
                h ^= (bits >> (8 * i)) & 0xffu;
                h *= 0x100000001b3ull;
            }
        }
    char buf[32];
    std::snprintf(buf, sizeof buf, "fnv1a64:%016llx", static_cast<unsigned long long>(h));
    return buf;
}

}  // namespace spectex_test
