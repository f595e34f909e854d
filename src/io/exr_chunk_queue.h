#pragma once
// The ordered chunk queue of the core-API OpenEXR writer (io/exr_core_writer): a bounded set of
// chunk buffers, a compression task of the shared pool (base/task_pool) per filled buffer, and the
// chunks handed to the file in chunk order, whichever task finished first. The writer packs the
// chunks and owns the header; this is where the memory bound and the order are kept.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "base/task_pool.h"
#include "io/exr_zip.h"
#include "io/spectral_exr_writer.h"

namespace spectex {

// One chunk: packed rows (a scanline block or a tile); after compression, the bytes to write.
struct ExrChunk {
    std::vector<uint8_t> data;
    size_t raw_bytes = 0, bytes = 0;
    int index = 0, rows = 0, filled = 0;
    int tx = 0, ty = 0, level = 0;  // tiled files
};

class ExrChunkQueue {
  public:
    // Writes one chunk to the file; throws Error naming the file when it cannot. Called with the
    // chunks in index order, one at a time, from any thread.
    using WriteChunk = std::function<void(const ExrChunk&)>;

    // name: the file, for messages. max_buffers: the most chunk buffers ever allocated, each of
    // max_chunk_bytes. deflaters: the ZIP compressors (io/exr_zip), or null to write chunks as
    // packed.
    ExrChunkQueue(std::string name, int max_buffers, size_t max_chunk_bytes,
                  std::unique_ptr<DeflaterPool> deflaters, WriteChunk write);
    ~ExrChunkQueue();  // waits for the tasks still running (they use the buffers)
    ExrChunkQueue(const ExrChunkQueue&) = delete;
    ExrChunkQueue& operator=(const ExrChunkQueue&) = delete;

    // The next chunk to fill (index = chunks started so far, filled = 0, data max_chunk_bytes
    // long), once a buffer is free: when none is, the caller finishes the oldest compression
    // itself. Throws the first error of a task.
    ExrChunk& acquire();
    // Hands a filled chunk (raw_bytes set) over to be compressed and written in its turn.
    void submit(ExrChunk& c);
    // Waits for every chunk submitted (compressed and written, or failed).
    void drain();
    // Throws the first error of a compression or a write, if any.
    void rethrow();

    int started() const { return next_chunk_; }  // chunks acquired so far
    int written() const;                         // chunks written so far
    // wait_seconds, compress_seconds, chunk_bytes, buffers and raw_chunks (pack_seconds is the
    // writer's).
    SpectralExrWriter::Timing timing() const;

  private:
    void write_ready();
    void compress_task(ExrChunk* c);
    bool finish_oldest();

    std::string name_;
    int max_buffers_;
    size_t max_chunk_bytes_;
    std::unique_ptr<DeflaterPool> deflaters_;
    WriteChunk write_;

    // Chunk buffers: `free_` ones wait to be filled; each filled one becomes a compression task of
    // the shared pool (`pending_`, in chunk order, touched by the caller's thread only); `done_`
    // holds compressed chunks until every earlier chunk is written (the file's line order is
    // increasing).
    std::vector<std::unique_ptr<ExrChunk>> all_;
    std::vector<ExrChunk*> free_;
    std::deque<Task> pending_;
    std::map<int, ExrChunk*> done_;
    int next_chunk_ = 0;     // index of the next chunk to start filling
    int next_write_ = 0;     // index of the next chunk to write
    mutable std::mutex mu_;  // guards everything above and the error
    std::mutex write_mu_;    // serialises writes to the file
    std::exception_ptr error_;
    SpectralExrWriter::Timing stats_;
    mutable std::mutex stats_mu_;
};

}  // namespace spectex
