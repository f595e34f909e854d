#pragma once
// Reads the reflective spectra of a spectral OpenEXR (Fichet 2021 layout): a band of rows, or a
// few pixels, never more than the rows asked for (OpenEXR decodes only the chunks or tiles that
// hold them). Shared by sample, render and plot.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "io/alpha_kind.h"
#include "io/spectral_exr_info.h"

namespace spectex {

// "none", "associated" (OpenEXR's convention for A when nothing says otherwise) or "unassociated"
// (spectex:alpha says so).
AlphaKind alpha_kind(const SpectralExrInfo& info);

struct PixelSpectrum {
    int x = 0, y = 0;           // data window coordinates, as in the file
    std::vector<float> values;  // one per bin, in wavelength order, as stored
    float alpha = 1.0f;         // A, or 1 without an alpha channel
};

class SpectralReader {
  public:
    // Throws Error("<path>: <cause>") for unreadable and non-spectral files.
    explicit SpectralReader(const std::string& path);
    ~SpectralReader();
    SpectralReader(const SpectralReader&) = delete;
    SpectralReader& operator=(const SpectralReader&) = delete;

    const SpectralExrInfo& info() const { return info_; }
    const std::string& path() const { return info_.path; }
    int bins() const { return static_cast<int>(info_.reflective.size()); }
    std::vector<double> wavelengths() const;
    AlphaKind alpha() const { return alpha_; }  // alpha_kind()

    // Rows [y0, y0 + rows) of the data window (0-based) into bin-major planes: bin k of pixel
    // (x, y0 + r) at planes[k * plane_stride + r * width + x]; A (or 1) into alpha when not null.
    void read_rows(int y0, int rows, float* planes, size_t plane_stride, float* alpha);
    // Rows per band that keeps one band of float planes near `band_bytes`, rounded to whole chunks.
    int band_rows(size_t band_bytes) const;

    // The spectra of pixels given in data window coordinates, in the order asked; each row is read
    // once. Throws Error("<path>: pixel X,Y is outside the data window x0,y0 - x1,y1").
    std::vector<PixelSpectrum> read_pixels(const std::vector<std::pair<int, int>>& xy);

  private:
    // read_rows for a file the direct decoder does not take (tiled, other compressions).
    void read_checked(int y0, int rows, float* planes, size_t plane_stride, float* alpha);
    struct Impl;
    SpectralExrInfo info_;
    AlphaKind alpha_ = AlphaKind::None;
    std::unique_ptr<Impl> impl_;
};

}  // namespace spectex
