// The core writer's ordered chunk queue (io/exr_chunk_queue) on its own, without OpenEXR: chunks
// reach the file in index order whichever compression finishes first, no more buffers are made
// than allowed however many chunks pass, and a write that fails is the error the caller gets,
// without a hang. (exr_writer_test.cpp reads whole files back through OpenEXR.)
#include "io/exr_chunk_queue.h"

#include <gtest/gtest.h>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "base/error.h"

using namespace spectex;

namespace {

constexpr size_t kChunkBytes = 4096;

// Fills chunk c with bytes that depend on its index (some compress, some do not).
void fill(ExrChunk& c) {
    uint32_t x = 2654435761u * static_cast<uint32_t>(c.index + 1);
    for (size_t i = 0; i < kChunkBytes; ++i) {
        x = x * 1664525u + 1013904223u;
        c.data[i] = c.index % 2 ? static_cast<uint8_t>(x >> 24) : static_cast<uint8_t>(i / 64);
    }
    c.raw_bytes = kChunkBytes;
}

struct Written {
    std::mutex mu;
    std::vector<int> order;
    std::vector<size_t> bytes;
};

void run_chunks(bool compress, int chunks, int buffers, Written& w) {
    ExrChunkQueue q("test.exr", buffers, kChunkBytes,
                    compress ? std::make_unique<DeflaterPool>(4, "test.exr") : nullptr,
                    [&w](const ExrChunk& c) {
                        std::lock_guard<std::mutex> lock(w.mu);
                        w.order.push_back(c.index);
                        w.bytes.push_back(c.bytes);
                    });
    for (int i = 0; i < chunks; ++i) {
        ExrChunk& c = q.acquire();
        EXPECT_EQ(c.index, i);
        fill(c);
        q.submit(c);
    }
    q.drain();
    q.rethrow();
    EXPECT_EQ(q.started(), chunks);
    EXPECT_EQ(q.written(), chunks);
    // The memory bound: buffers are reused, never more than asked for.
    EXPECT_LE(q.timing().buffers, buffers);
    EXPECT_EQ(q.timing().chunk_bytes, kChunkBytes);
}

}  // namespace

TEST(ExrChunkQueue, WritesStoredChunksInOrder) {
    Written w;
    run_chunks(false, 40, 1, w);
    ASSERT_EQ(w.order.size(), 40u);
    for (int i = 0; i < 40; ++i) {
        EXPECT_EQ(w.order[static_cast<size_t>(i)], i);
        EXPECT_EQ(w.bytes[static_cast<size_t>(i)], kChunkBytes);  // stored as packed
    }
}

TEST(ExrChunkQueue, WritesCompressedChunksInOrderWithinItsBuffers) {
    Written w;
    run_chunks(true, 64, 3, w);
    ASSERT_EQ(w.order.size(), 64u);
    for (int i = 0; i < 64; ++i) {
        EXPECT_EQ(w.order[static_cast<size_t>(i)], i);
        // Even chunks are runs of equal bytes and shrink; odd ones are noise and stay raw.
        if (i % 2 == 0) EXPECT_LT(w.bytes[static_cast<size_t>(i)], kChunkBytes / 4);
        EXPECT_LE(w.bytes[static_cast<size_t>(i)], kChunkBytes);
    }
}

TEST(ExrChunkQueue, AFailedWriteIsTheCallersError) {
    for (bool compress : {false, true}) {
        int writes = 0;
        ExrChunkQueue q("full.exr", 2, kChunkBytes,
                        compress ? std::make_unique<DeflaterPool>(4, "full.exr") : nullptr,
                        [&writes](const ExrChunk& c) {
                            if (c.index == 3) throw Error("full.exr: write failed: No space left");
                            ++writes;
                        });
        std::string what;
        try {
            for (int i = 0; i < 20; ++i) {
                ExrChunk& c = q.acquire();
                fill(c);
                q.submit(c);
            }
            q.drain();
            q.rethrow();
        } catch (const Error& e) {
            what = e.what();
        }
        q.drain();
        EXPECT_EQ(what, "full.exr: write failed: No space left") << "compress " << compress;
        EXPECT_EQ(writes, 3) << "no chunk is written after the one that failed";
    }
}
