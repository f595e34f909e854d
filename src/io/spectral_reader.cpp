#include "io/spectral_reader.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfTileDescription.h>

#include <algorithm>
#include <map>

#include "base/error.h"
#include "io/exr_compression.h"
#include "io/exr_preflight.h"
#include "io/provenance_keys.h"

namespace spectex {

AlphaKind alpha_kind(const SpectralExrInfo& info) {
    if (!info.alpha) return AlphaKind::None;
    for (const auto& [k, v] : info.attributes)
        if (k == provenance_key::kAlpha && v == to_string(AlphaKind::Unassociated))
            return AlphaKind::Unassociated;
    return AlphaKind::Associated;
}

struct SpectralReader::Impl {
    std::unique_ptr<Imf::InputFile> file;
};

SpectralReader::SpectralReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
    info_ = read_spectral_exr_info(path);  // throws "<path>: <cause>"
    alpha_ = alpha_kind(info_);
    try {
        exr_preflight(path);
        impl_->file = std::make_unique<Imf::InputFile>(path.c_str());
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(path + ": cannot open the OpenEXR file: " + e.what());
    }
}

SpectralReader::~SpectralReader() = default;

std::vector<double> SpectralReader::wavelengths() const {
    std::vector<double> l;
    for (const auto& b : info_.reflective) l.push_back(b.lambda);
    return l;
}

void SpectralReader::read_rows(int y0, int rows, float* planes, size_t plane_stride, float* alpha) {
    const Imf::Header& h = impl_->file->header();
    const Imath::Box2i dw = h.dataWindow();
    const size_t w = static_cast<size_t>(info_.width);
    try {
        Imf::FrameBuffer fb;
        const Imath::V2i origin(dw.min.x, dw.min.y + y0);
        for (size_t k = 0; k < info_.reflective.size(); ++k)
            fb.insert(
                info_.reflective[k].channel,
                Imf::Slice::Make(Imf::FLOAT, planes + k * plane_stride, origin,
                                 static_cast<int64_t>(w), rows, sizeof(float), sizeof(float) * w));
        if (alpha && info_.alpha)
            fb.insert("A", Imf::Slice::Make(Imf::FLOAT, alpha, origin, static_cast<int64_t>(w),
                                            rows, sizeof(float), sizeof(float) * w));
        impl_->file->setFrameBuffer(fb);
        impl_->file->readPixels(dw.min.y + y0, dw.min.y + y0 + rows - 1);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(info_.path + ": cannot read the pixels: " + e.what());
    }
    if (alpha && !info_.alpha) std::fill(alpha, alpha + w * static_cast<size_t>(rows), 1.0f);
}

int SpectralReader::band_rows(size_t band_bytes) const {
    const Imf::Header& h = impl_->file->header();
    int chunk = 1;
    if (h.hasTileDescription()) {
        chunk = std::max(1, static_cast<int>(h.tileDescription().ySize));
    } else if (const ExrCompression* c = ExrCompression::find(static_cast<int>(h.compression()))) {
        chunk = c->lines_per_chunk;
    }
    const size_t row_bytes =
        static_cast<size_t>(info_.width) * info_.reflective.size() * sizeof(float);
    int rows = static_cast<int>(std::max<size_t>(1, band_bytes / std::max<size_t>(row_bytes, 1)));
    if (rows >= chunk)
        rows = rows / chunk * chunk;
    else if (static_cast<size_t>(chunk) * row_bytes <= 2 * band_bytes)
        rows = chunk;
    return std::max(1, std::min(rows, info_.height));
}

std::vector<PixelSpectrum> SpectralReader::read_pixels(const std::vector<std::pair<int, int>>& xy) {
    for (const auto& [x, y] : xy)
        if (x < info_.data_x0 || x > info_.data_x1 || y < info_.data_y0 || y > info_.data_y1)
            throw Error(info_.path + ": pixel " + std::to_string(x) + "," + std::to_string(y) +
                        " is outside the data window " + std::to_string(info_.data_x0) + "," +
                        std::to_string(info_.data_y0) + " - " + std::to_string(info_.data_x1) +
                        "," + std::to_string(info_.data_y1));
    const size_t w = static_cast<size_t>(info_.width), n = info_.reflective.size();
    std::vector<PixelSpectrum> out(xy.size());
    std::map<int, std::vector<size_t>> by_row;  // rows in file order: each is decoded once
    for (size_t i = 0; i < xy.size(); ++i) by_row[xy[i].second].push_back(i);
    std::vector<float> planes(w * n), alpha(w);
    for (const auto& [y, which] : by_row) {
        read_rows(y - info_.data_y0, 1, planes.data(), w, alpha.data());
        for (size_t i : which) {
            PixelSpectrum& p = out[i];
            p.x = xy[i].first;
            p.y = y;
            const size_t col = static_cast<size_t>(p.x - info_.data_x0);
            p.values.resize(n);
            for (size_t k = 0; k < n; ++k) p.values[k] = planes[k * w + col];
            p.alpha = alpha[col];
        }
    }
    return out;
}

}  // namespace spectex
