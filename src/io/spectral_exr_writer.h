#pragma once
// Writes the Fichet–Pacanowski–Wilkie (JCGT 2021) reflective layout: channels T.<λ>nm, optional A
// and preview R,G,B, header spectralLayoutVersion = "1.0", through an AtomicFile.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "io/exr_compression.h"
#include "io/pixel_window.h"

namespace spectex {

class AtomicFile;

enum class SampleType { Half, Float };

struct SpectralExrLayout : PixelWindows {
    std::vector<double> lambda;
    SampleType type = SampleType::Half;
    bool alpha = false;
    SampleType alpha_type = SampleType::Half;
    bool preview = false;
    ExrCompression compression = ExrCompression::parse(ExrCompression::kDefault);
    std::vector<std::pair<std::string, std::string>> attributes;  // extra string attributes
    int threads = 1;  // OpenEXR worker threads for this file (from the global pool)
    // Tiled output (tile_width > 0), optionally MIP-mapped (levels rounded down, as maketx does).
    int tile_width = 0, tile_height = 0;
    bool mipmap = false;
    // The "wrapmodes" attribute ("s,t", maketx's spelling): "" writes black,black in a tiled file
    // (maketx's default) and nothing in a scanline one.
    std::string wrapmodes;
    // Files whose compression the table gives the core writer (ExrCompression::core_writer),
    // scanline or tiled, go through the core-API writer (bounded memory, libdeflate) unless writer
    // is "imf"; "auto" also reads $SPECTEX_EXR_WRITER (core or imf).
    std::string writer = "auto";
    int zip_level = 4;  // libdeflate level for the core writer (Imf's zlib uses OpenEXR's default)
};

// The string attributes OpenImageIO's texture system looks for, written by both back ends: in a
// tiled file textureformat "Plain Texture" and wrapmodes (layout.wrapmodes, else "black,black"),
// as maketx writes them; in a scanline file wrapmodes only when layout.wrapmodes is given.
std::vector<std::pair<std::string, std::string>> texture_attributes(
    const SpectralExrLayout& layout);

class SpectralExrWriter {
  public:
    SpectralExrWriter(AtomicFile& file, const SpectralExrLayout& layout);
    // Whether a writer for this layout uses the core-API writer (throws on an unknown writer name).
    static bool uses_core(const SpectralExrLayout& layout);
    ~SpectralExrWriter();

    // Writes the next `rows` rows. spectral: bin k of pixel i at spectral[k*plane_stride + i]
    // (uint16_t half bits or float, as layout.type); alpha and preview (r,g,b planes) are float,
    // width*rows each, and ignored when the layout has none.
    void write_rows(int rows, const void* spectral, size_t plane_stride, const float* alpha,
                    const float* preview_r, const float* preview_g, const float* preview_b);
    // Tiled files: writes rows [row0, row0 + rows) of MIP level `level` (whole tile rows; the
    // planes are level_width wide). Levels and tile rows may come in any order.
    void write_level_rows(int level, int row0, int rows, const void* spectral, size_t plane_stride,
                          const float* alpha, const float* preview_r, const float* preview_g,
                          const float* preview_b);
    int levels() const;  // 1 unless MIP-mapped
    int level_width(int level) const;
    int level_height(int level) const;
    // Completes the file (offset table) and flushes it to the AtomicFile.
    void finish();
    // Which writer: "core" (openexr_core + libdeflate) or "imf" (OpenEXR's C++ library).
    const char* writer_name() const;
    // Core writer only (zeros otherwise), valid after finish().
    struct Timing {
        double pack_seconds = 0;      // caller thread: copying rows into chunks
        double wait_seconds = 0;      // caller thread: waiting for a free chunk buffer
        double compress_seconds = 0;  // summed over the compression workers
        size_t chunk_bytes = 0;       // packed bytes of the largest chunk
        int buffers = 0;              // chunk buffers allocated
        int raw_chunks = 0;  // compressed files: chunks stored raw (deflate did not shrink them)
    };
    Timing timing() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace spectex
