#pragma once
// OpenEXR's ZIP and ZIPS block compression, as OpenEXRCore keeps it apart (internal_zip.c): the
// pre-pass that makes samples compress (even bytes, then odd bytes, then byte differences), zlib
// deflate by libdeflate, and the rule that a block deflate cannot shrink is stored raw (readers
// tell the two apart by size). Compressors are pooled: one per compression running at once, kept
// for the next block.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

struct libdeflate_compressor;

namespace spectex {

// EXR's ZIP pre-pass over n bytes, into out (n bytes).
void zip_prepare(const uint8_t* in, size_t n, uint8_t* out);
// Its inverse: prepared (n bytes, changed) back to the samples in out.
void zip_restore(uint8_t* prepared, size_t n, uint8_t* out);

class DeflaterPool {
  public:
    // level: libdeflate's 1 (fastest) .. 12 (smallest); `name` names the file in errors.
    DeflaterPool(int level, std::string name);
    ~DeflaterPool();
    DeflaterPool(const DeflaterPool&) = delete;
    DeflaterPool& operator=(const DeflaterPool&) = delete;

    // Compresses the n bytes at block in place, as EXR stores a ZIP block: returns the bytes to
    // write (n when it is stored raw, the block then unchanged). block has room for n bytes.
    // Thread-safe. Throws Error when no compressor can be made. *stored_raw says which it was.
    size_t compress(uint8_t* block, size_t n, bool* stored_raw);

  private:
    struct Deflater;
    std::unique_ptr<Deflater> take();
    void give(std::unique_ptr<Deflater> d);

    int level_;
    std::string name_;
    std::mutex mu_;
    std::vector<std::unique_ptr<Deflater>> idle_;
};

}  // namespace spectex
