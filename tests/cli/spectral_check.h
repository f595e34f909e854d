#pragma once
// An independent reader and colorimeter for spectral EXRs, for the end-to-end tests. It shares
// nothing with spectex's spectral code: its own CSV parsing, interpolation, CIE integration,
// RGB<->XYZ matrix and 3x3 inverse, and OpenEXR's C++ API for the pixels.
#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace spectex_test {

using Mat3 = std::array<std::array<double, 3>, 3>;

inline Mat3 inverse3(const Mat3& m) {
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                 m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    Mat3 r;
    r[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / det;
    r[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det;
    r[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det;
    r[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) / det;
    r[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det;
    r[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det;
    r[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / det;
    r[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / det;
    r[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det;
    return r;
}

// Columns of numbers from a CSV with '#' comments and one header line.
inline std::vector<std::vector<double>> read_columns(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot open " + path);
    std::string line;
    bool header = false;
    std::vector<std::vector<double>> cols;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        if (!header) {
            header = true;
            continue;
        }
        std::stringstream ss(line);
        std::string cell;
        size_t i = 0;
        while (std::getline(ss, cell, ',')) {
            if (cols.size() <= i) cols.emplace_back();
            cols[i++].push_back(std::stod(cell));
        }
    }
    return cols;
}

inline double interp(const std::vector<double>& x, const std::vector<double>& y, double at) {
    auto it = std::lower_bound(x.begin(), x.end(), at - 1e-9);
    size_t i = static_cast<size_t>(it - x.begin());
    if (i < x.size() && std::fabs(x[i] - at) < 1e-9) return y[i];
    if (i == 0 || i >= x.size()) throw std::runtime_error("wavelength outside table");
    double t = (at - x[i - 1]) / (x[i] - x[i - 1]);
    return y[i - 1] + t * (y[i] - y[i - 1]);
}

// Spectrum -> linear sRGB under D65 with CIE 1931 2°, on the given bins (equal weights), with the
// RGB->XYZ matrix built from the sRGB primaries and the white of D65 integrated on the same bins.
struct Colorimeter {
    std::vector<std::array<double, 3>> rgb_weight;  // per bin
    explicit Colorimeter(const std::vector<double>& lambda, const std::string& data_dir) {
        auto obs = read_columns(data_dir + "/spectral/observer_cie1931-2.csv");
        auto d65 = read_columns(data_dir + "/spectral/illuminant_D65.csv");
        std::vector<std::array<double, 3>> xyz(lambda.size());
        double ysum = 0;
        for (size_t k = 0; k < lambda.size(); ++k) {
            double e = interp(d65[0], d65[1], lambda[k]);
            for (int c = 0; c < 3; ++c) xyz[k][c] = e * interp(obs[0], obs[c + 1], lambda[k]);
            ysum += xyz[k][1];
        }
        double white[3] = {0, 0, 0};
        for (auto& v : xyz)
            for (int c = 0; c < 3; ++c) white[c] += (v[c] /= ysum);
        const double xy[3][2] = {{0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}};
        Mat3 P;
        for (int j = 0; j < 3; ++j) {
            P[0][j] = xy[j][0] / xy[j][1];
            P[1][j] = 1.0;
            P[2][j] = (1 - xy[j][0] - xy[j][1]) / xy[j][1];
        }
        Mat3 Pi = inverse3(P);
        double s[3];
        for (int i = 0; i < 3; ++i)
            s[i] = Pi[i][0] * white[0] + Pi[i][1] * white[1] + Pi[i][2] * white[2];
        Mat3 M;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) M[i][j] = P[i][j] * s[j];
        Mat3 Mi = inverse3(M);
        rgb_weight.resize(lambda.size());
        for (size_t k = 0; k < lambda.size(); ++k)
            for (int i = 0; i < 3; ++i)
                rgb_weight[k][i] =
                    Mi[i][0] * xyz[k][0] + Mi[i][1] * xyz[k][1] + Mi[i][2] * xyz[k][2];
    }
};

// Reflective channels of an EXR, sorted by wavelength ("T.<λ>nm", comma or dot).
inline std::vector<std::pair<double, std::string>> spectral_channels(const Imf::Header& h) {
    std::vector<std::pair<double, std::string>> v;
    for (auto it = h.channels().begin(); it != h.channels().end(); ++it) {
        std::string n = it.name();
        if (n.size() > 4 && n.compare(0, 2, "T.") == 0 && n.compare(n.size() - 2, 2, "nm") == 0) {
            std::string num = n.substr(2, n.size() - 4);
            std::replace(num.begin(), num.end(), ',', '.');
            v.emplace_back(std::stod(num), n);
        }
    }
    std::sort(v.begin(), v.end());
    return v;
}

// Calls fn(x, y, spectrum, alpha) for every pixel, reading `band` rows at a time as float.
inline void for_each_spectrum(
    const std::string& path,
    const std::function<void(int, int, const std::vector<float>&, float)>& fn, int band = 64) {
    Imf::InputFile file(path.c_str());
    const auto& h = file.header();
    auto chans = spectral_channels(h);
    const bool has_a = h.channels().findChannel("A") != nullptr;
    auto dw = h.dataWindow();
    const int w = dw.max.x - dw.min.x + 1;
    std::vector<float> buf(static_cast<size_t>(w) * band * (chans.size() + 1));
    std::vector<float> spec(chans.size());
    for (int y0 = dw.min.y; y0 <= dw.max.y; y0 += band) {
        int y1 = std::min(dw.max.y, y0 + band - 1);
        Imf::FrameBuffer fb;
        const size_t plane = static_cast<size_t>(w) * band;
        for (size_t k = 0; k <= chans.size(); ++k) {
            if (k == chans.size() && !has_a) break;
            char* base =
                reinterpret_cast<char*>(buf.data() + k * plane) -
                (static_cast<ptrdiff_t>(y0) * w + dw.min.x) * static_cast<ptrdiff_t>(sizeof(float));
            fb.insert(k < chans.size() ? chans[k].second : "A",
                      Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * w));
        }
        file.setFrameBuffer(fb);
        file.readPixels(y0, y1);
        for (int y = y0; y <= y1; ++y)
            for (int x = 0; x < w; ++x) {
                size_t i = static_cast<size_t>(y - y0) * w + x;
                for (size_t k = 0; k < chans.size(); ++k) spec[k] = buf[k * plane + i];
                fn(dw.min.x + x, y, spec, has_a ? buf[chans.size() * plane + i] : 1.0f);
            }
    }
}

inline double iec_srgb_to_linear(double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}
inline int iec_linear_to_code(double l) {
    double v = l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1 / 2.4) - 0.055;
    return static_cast<int>(std::lround(std::min(1.0, std::max(0.0, v)) * 255.0));
}

}  // namespace spectex_test
