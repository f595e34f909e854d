#pragma once
// An OpenEXR writer on OpenEXR's C core API (openexr_core) for the compressions the table gives it
// (ExrCompression::core_writer), scanline or tiled (one level or MIP-mapped, levels rounded down).
//
// Why not Imf::OutputFile: OpenEXR 3.1's C++ writer keeps 2×threads line buffers, each with its
// own compression buffers, whatever the chunk size (about 630 MB at 4K and 401 bins), and
// compresses with zlib. Here the chunks in flight are capped (threads + 1 packed chunks plus one
// scratch buffer per worker), and ZIP blocks are deflated with libdeflate: the same standard
// zlib stream of the same predicted, byte-interleaved block that OpenEXR ≥ 3.2 writes with
// libdeflate itself, so every reader reads it.
#include <memory>
#include <string>
#include <vector>

#include "io/spectral_exr_writer.h"

namespace spectex {

class ExrCoreWriter {
  public:
    static bool supports(const std::string& compression);  // ExrCompression::core_writer
    // fd: an open, empty, writable file (the AtomicFile's); name: for messages. The layout's
    // compression must be one that supports() takes; its writer field is not looked at.
    ExrCoreWriter(int fd, const std::string& name, const SpectralExrLayout& layout);
    ~ExrCoreWriter();  // joins the workers; an unfinished file is left to the AtomicFile to discard

    // The next `rows` rows. spectral: sample of bin k, pixel i at spectral[k*plane_stride + i]
    // (half bits or float, as the channels say); alpha and preview planes are float. The data
    // may be reused as soon as the call returns.
    void write_rows(int rows, const void* spectral, size_t plane_stride, const float* alpha,
                    const float* preview_r, const float* preview_g, const float* preview_b);
    // Tiled files: rows [row0, row0 + rows) of MIP level `level` (planes level_width wide), whole
    // tile rows, levels and rows in increasing order (the file's chunk order).
    void write_level_rows(int level, int row0, int rows, const void* spectral, size_t plane_stride,
                          const float* alpha, const float* preview_r, const float* preview_g,
                          const float* preview_b);
    int levels() const;
    int level_width(int level) const;
    int level_height(int level) const;
    // Waits for the last chunks, writes the offset table; throws the first error (naming the file).
    void finish();

    SpectralExrWriter::Timing stats() const;  // valid after finish()

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace spectex
