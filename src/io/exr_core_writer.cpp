#include "io/exr_core_writer.h"

#include <openexr.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <mutex>

#include "base/error.h"
#include "base/task_pool.h"
#include "io/exr_chunk_queue.h"
#include "io/exr_compression.h"
#include "io/exr_zip.h"
#include "spectral/expand.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "EXR chunks are little-endian; packing copies native samples and needs a little-endian host"
#endif

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// A channel of the file and where its samples come from.
struct CoreChannel {
    std::string name;
    bool half = true;  // sample type in the file
    enum Source { Spectral, Alpha, PreviewR, PreviewG, PreviewB } source = Spectral;
    int bin = 0;  // for Spectral: plane index
};

}  // namespace

bool ExrCoreWriter::supports(const std::string& compression) {
    const ExrCompression* c = ExrCompression::find(compression);
    return c && c->core_writer;
}

struct ExrCoreWriter::Impl {
    SpectralExrLayout L;
    std::string name;
    int fd = -1;
    exr_context_t ctxt = nullptr;
    std::vector<CoreChannel> channels;  // file order
    size_t row_bytes = 0;               // scanline files: bytes of one packed row
    size_t pixel_bytes = 0;             // bytes of one pixel over all channels
    int lines_per_chunk = 1, chunk_count = 0;
    bool compress = false;
    bool tiled = false;
    std::vector<std::pair<int, int>> level_size;  // tiled: width, height of each level
    int next_level = 0, next_row = 0;             // tiled: where the caller must continue
    ExrChunk* current = nullptr;                  // scanline files: the chunk being filled
    // The chunks in flight, compressed by the pool and written in order (io/exr_chunk_queue).
    std::unique_ptr<ExrChunkQueue> queue;
    std::mutex mu;           // guards the two messages below
    std::string io_error;    // the first write() failure, with errno's text
    std::string core_error;  // the last message from OpenEXR's core
    double pack_seconds = 0;

    static int64_t write_fn(exr_const_context_t, void* user, const void* buffer, uint64_t sz,
                            uint64_t offset, exr_stream_error_func_ptr_t) {
        auto* self = static_cast<Impl*>(user);
        const char* p = static_cast<const char*>(buffer);
        uint64_t done = 0;
        while (done < sz) {
            ssize_t n = ::pwrite(self->fd, p + done, static_cast<size_t>(sz - done),
                                 static_cast<off_t>(offset + done));
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                const int e = n < 0 ? errno : EIO;
                std::lock_guard<std::mutex> lock(self->mu);
                if (self->io_error.empty())
                    self->io_error = self->name + ": write failed: " + std::strerror(e);
                return -1;
            }
            done += static_cast<uint64_t>(n);
        }
        return static_cast<int64_t>(sz);
    }
    static void error_fn(exr_const_context_t ctxt, exr_result_t code, const char* msg) {
        void* user = nullptr;
        if (exr_get_user_data(ctxt, &user) == EXR_ERR_SUCCESS && user) {
            auto* self = static_cast<Impl*>(user);
            std::lock_guard<std::mutex> lock(self->mu);
            self->core_error = std::string(exr_get_error_code_as_string(code)) +
                               (msg ? std::string(": ") + msg : "");
        }
    }

    // Throws the error that explains a failure best: the system's, then OpenEXR's.
    [[noreturn]] void fail(const std::string& what, exr_result_t rv) {
        std::lock_guard<std::mutex> lock(mu);
        if (!io_error.empty()) throw Error(io_error);
        std::string why = core_error.empty() ? exr_get_default_error_message(rv) : core_error;
        throw Error(name + ": " + what + ": " + why);
    }
    void check(exr_result_t rv, const char* what) {
        if (rv != EXR_ERR_SUCCESS) fail(what, rv);
    }

    // Hands one compressed chunk to OpenEXR's core (the queue calls it in chunk order).
    void write_chunk(const ExrChunk& c) {
        const exr_result_t rv =
            tiled ? exr_write_tile_chunk(ctxt, 0, c.tx, c.ty, c.level, c.level, c.data.data(),
                                         c.bytes)
                  : exr_write_scanline_chunk(ctxt, 0, L.y + c.index * lines_per_chunk,
                                             c.data.data(), c.bytes);
        if (rv != EXR_ERR_SUCCESS) fail("writing chunk " + std::to_string(c.index), rv);
    }

    // The next chunk; a scanline chunk knows its rows and bytes from its index.
    ExrChunk& acquire() {
        ExrChunk& c = queue->acquire();
        if (!tiled) {
            c.rows = std::min(lines_per_chunk, L.height - c.index * lines_per_chunk);
            c.raw_bytes = row_bytes * static_cast<size_t>(c.rows);
        }
        return c;
    }

    // Packs one line of cw pixels of every channel, in file order, at dst (EXR's layout within a
    // chunk: a line holds each channel's samples in turn); src_off indexes the caller's planes.
    // Returns the end of the line.
    uint8_t* pack_line(uint8_t* dst, size_t cw, size_t src_off, const void* spectral,
                       size_t plane_stride, const float* alpha, const float* pr, const float* pg,
                       const float* pb) const {
        for (const CoreChannel& C : channels) {
            const size_t es = C.half ? 2 : 4;
            if (C.source == CoreChannel::Spectral) {
                std::memcpy(
                    dst,
                    static_cast<const uint8_t*>(spectral) + (C.bin * plane_stride + src_off) * es,
                    cw * es);
            } else {
                const float* src = C.source == CoreChannel::Alpha      ? alpha
                                   : C.source == CoreChannel::PreviewR ? pr
                                   : C.source == CoreChannel::PreviewG ? pg
                                                                       : pb;
                if (C.half)
                    floats_to_half(src + src_off, reinterpret_cast<uint16_t*>(dst), cw);
                else
                    std::memcpy(dst, src + src_off, cw * sizeof(float));
            }
            dst += cw * es;
        }
        return dst;
    }
};

ExrCoreWriter::ExrCoreWriter(int fd, const std::string& name, const SpectralExrLayout& layout)
    : impl_(std::make_unique<Impl>()) {
    Impl& I = *impl_;
    I.L = layout;
    const SpectralExrLayout& L = I.L;
    I.name = name;
    I.fd = fd;
    const std::string& cname = L.compression.name;
    if (!supports(cname)) throw Error("internal: the core writer does not write " + cname);
    const exr_compression_t comp = static_cast<exr_compression_t>(L.compression.id);
    I.tiled = L.tile_width > 0;
    I.lines_per_chunk = I.tiled ? L.tile_height : L.compression.lines_per_chunk;
    I.compress = comp != EXR_COMPRESSION_NONE;
    I.chunk_count = (L.height + I.lines_per_chunk - 1) / I.lines_per_chunk;  // tiled: set below

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.user_data = &I;
    init.write_fn = &Impl::write_fn;
    init.error_handler_fn = &Impl::error_fn;
    init.zip_level = L.zip_level;
    I.check(exr_start_write(&I.ctxt, name.c_str(), EXR_WRITE_FILE_DIRECTLY, &init),
            "cannot start the file");
    int part = 0;
    I.check(
        exr_add_part(I.ctxt, nullptr, I.tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part),
        "cannot add the image part");
    // The attribute types hold their fields in anonymous unions: set them by name.
    exr_attr_box2i_t data{};
    data.min.x = L.x;
    data.min.y = L.y;
    data.max.x = L.x + L.width - 1;
    data.max.y = L.y + L.height - 1;
    exr_attr_box2i_t display{};
    display.min.x = L.full_x;
    display.min.y = L.full_y;
    display.max.x = L.full_x + L.full_width - 1;
    display.max.y = L.full_y + L.full_height - 1;
    exr_attr_v2f_t center{};
    I.check(exr_initialize_required_attr(I.ctxt, part, &display, &data, 1.0f, &center, 1.0f,
                                         EXR_LINEORDER_INCREASING_Y, comp),
            "cannot set the header");
    const bool half = L.type == SampleType::Half;
    for (size_t k = 0; k < L.lambda.size(); ++k)
        I.channels.push_back({reflective_channel_name(L.lambda[k]), half, CoreChannel::Spectral,
                              static_cast<int>(k)});
    if (L.alpha)
        I.channels.push_back({"A", L.alpha_type == SampleType::Half, CoreChannel::Alpha, 0});
    if (L.preview) {
        I.channels.push_back({"R", half, CoreChannel::PreviewR, 0});
        I.channels.push_back({"G", half, CoreChannel::PreviewG, 0});
        I.channels.push_back({"B", half, CoreChannel::PreviewB, 0});
    }
    std::sort(I.channels.begin(), I.channels.end(), [](const CoreChannel& a, const CoreChannel& b) {
        return std::strcmp(a.name.c_str(), b.name.c_str()) < 0;
    });
    for (const auto& c : I.channels) {
        // Linear = 0 is what Imf::Channel writes by default (pLinear false).
        if (exr_add_channel(I.ctxt, part, c.name.c_str(), c.half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                            EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1) != EXR_ERR_SUCCESS)
            I.fail("cannot add channel " + c.name, EXR_ERR_INVALID_ARGUMENT);
        I.pixel_bytes += c.half ? 2 : 4;
    }
    I.row_bytes = I.pixel_bytes * static_cast<size_t>(L.width);
    if (I.tiled) {
        I.check(exr_set_tile_descriptor(I.ctxt, part, static_cast<uint32_t>(L.tile_width),
                                        static_cast<uint32_t>(L.tile_height),
                                        L.mipmap ? EXR_TILE_MIPMAP_LEVELS : EXR_TILE_ONE_LEVEL,
                                        EXR_TILE_ROUND_DOWN),
                "cannot set the tile description");
    }
    const exr_attr_chlist_t* list = nullptr;
    I.check(exr_get_channels(I.ctxt, part, &list), "cannot read back the channel list");
    for (int i = 0; i < list->num_channels; ++i)
        if (I.channels[static_cast<size_t>(i)].name != list->entries[i].name.str)
            throw Error(name + ": internal: channel order differs from OpenEXR's");
    // Attributes in name order, as OpenEXR's C++ writer stores them (the core keeps insertion
    // order).
    auto attributes = L.attributes;
    attributes.emplace_back("spectralLayoutVersion", "1.0");
    for (auto& kv : texture_attributes(L)) attributes.push_back(std::move(kv));
    std::sort(attributes.begin(), attributes.end());
    for (const auto& [k, v] : attributes)
        I.check(exr_attr_set_string(I.ctxt, part, k.c_str(), v.c_str()),
                ("cannot set attribute " + k).c_str());
    if (L.preview) {  // the preview channels are linear Rec.709 / sRGB primaries, D65 white
        exr_attr_chromaticities_t c{0.64f, 0.33f, 0.30f, 0.60f, 0.15f, 0.06f, 0.3127f, 0.3290f};
        I.check(exr_attr_set_chromaticities(I.ctxt, part, "chromaticities", &c),
                "cannot set chromaticities");
    }
    I.check(exr_write_header(I.ctxt), "cannot write the header");
    size_t max_chunk_bytes = 0;
    if (I.tiled) {
        int32_t lx = 0, ly = 0;
        I.check(exr_get_tile_levels(I.ctxt, part, &lx, &ly), "cannot count the levels");
        I.chunk_count = 0;
        for (int l = 0; l < lx; ++l) {
            int32_t w = 0, h = 0;
            I.check(exr_get_level_sizes(I.ctxt, part, l, l, &w, &h), "cannot size a level");
            I.level_size.emplace_back(w, h);
            I.chunk_count +=
                ((w + L.tile_width - 1) / L.tile_width) * ((h + L.tile_height - 1) / L.tile_height);
        }
        max_chunk_bytes =
            I.pixel_bytes * static_cast<size_t>(L.tile_width) * static_cast<size_t>(L.tile_height);
    } else {
        max_chunk_bytes = I.row_bytes * static_cast<size_t>(I.lines_per_chunk);
    }

    // Memory: L.threads + 1 chunk buffers (one being filled, the others compressing or waiting
    // for a worker), never more, whatever the bin count; a scratch block per compression running
    // at once, L.threads + 1 at most when the caller finishes the oldest itself (acquire).
    const int compressing = I.compress ? std::max(1, L.threads) : 0;
    I.queue = std::make_unique<ExrChunkQueue>(
        name, compressing + 1, max_chunk_bytes,
        I.compress ? std::make_unique<DeflaterPool>(L.zip_level, name) : nullptr,
        [&I](const ExrChunk& c) { I.write_chunk(c); });
    if (I.compress) TaskPool::shared().reserve(compressing);
}

ExrCoreWriter::~ExrCoreWriter() {
    if (impl_->queue)
        impl_->queue->drain();  // the tasks use the buffers and the context freed below
    if (impl_->ctxt)
        exr_finish(&impl_->ctxt);  // frees the context; the AtomicFile discards the data
}

void ExrCoreWriter::write_rows(int rows, const void* spectral, size_t plane_stride,
                               const float* alpha, const float* pr, const float* pg,
                               const float* pb) {
    Impl& I = *impl_;
    if (I.tiled) throw Error(I.name + ": internal: write_rows on a tiled file");
    const size_t w = static_cast<size_t>(I.L.width);
    for (int r = 0; r < rows; ++r) {
        if (!I.current) I.current = &I.acquire();
        auto t0 = Clock::now();
        ExrChunk& c = *I.current;
        I.pack_line(c.data.data() + static_cast<size_t>(c.filled) * I.row_bytes, w,
                    static_cast<size_t>(r) * w, spectral, plane_stride, alpha, pr, pg, pb);
        I.pack_seconds += since(t0);
        if (++c.filled == c.rows) {
            I.current = nullptr;
            I.queue->submit(c);
        }
    }
    I.queue->rethrow();
}

void ExrCoreWriter::write_level_rows(int level, int row0, int rows, const void* spectral,
                                     size_t plane_stride, const float* alpha, const float* pr,
                                     const float* pg, const float* pb) {
    Impl& I = *impl_;
    if (!I.tiled) throw Error(I.name + ": internal: write_level_rows on a scanline file");
    if (level >= static_cast<int>(I.level_size.size()))
        throw Error(I.name + ": internal: no level " + std::to_string(level));
    if (level != I.next_level || row0 != I.next_row)
        throw Error(I.name + ": internal: tiles must come in file order (level " +
                    std::to_string(I.next_level) + ", row " + std::to_string(I.next_row) +
                    " next)");
    const int lw = I.level_size[static_cast<size_t>(level)].first,
              lh = I.level_size[static_cast<size_t>(level)].second;
    const int tw = I.L.tile_width, th = I.L.tile_height;
    if (row0 % th != 0 || (rows % th != 0 && row0 + rows != lh))
        throw Error(I.name + ": internal: rows must be whole tile rows");
    const size_t w = static_cast<size_t>(lw);
    for (int y0 = row0; y0 < row0 + rows; y0 += th) {
        const int tile_rows = std::min(th, lh - y0);
        for (int x0 = 0; x0 < lw; x0 += tw) {
            const size_t cw = static_cast<size_t>(std::min(tw, lw - x0));
            ExrChunk& c = I.acquire();
            auto t0 = Clock::now();
            c.level = level;
            c.tx = x0 / tw;
            c.ty = y0 / th;
            c.rows = tile_rows;
            c.raw_bytes = I.pixel_bytes * cw * static_cast<size_t>(tile_rows);
            uint8_t* dst = c.data.data();
            for (int y = 0; y < tile_rows; ++y)
                dst = I.pack_line(dst, cw,
                                  static_cast<size_t>(y0 - row0 + y) * w + static_cast<size_t>(x0),
                                  spectral, plane_stride, alpha, pr, pg, pb);
            I.pack_seconds += since(t0);
            I.queue->submit(c);
        }
    }
    I.next_row = row0 + rows;
    if (I.next_row >= lh) {
        ++I.next_level;
        I.next_row = 0;
    }
    I.queue->rethrow();
}

int ExrCoreWriter::levels() const {
    return impl_->tiled ? static_cast<int>(impl_->level_size.size()) : 1;
}
int ExrCoreWriter::level_width(int level) const {
    return impl_->tiled ? impl_->level_size.at(static_cast<size_t>(level)).first : impl_->L.width;
}
int ExrCoreWriter::level_height(int level) const {
    return impl_->tiled ? impl_->level_size.at(static_cast<size_t>(level)).second : impl_->L.height;
}

void ExrCoreWriter::finish() {
    Impl& I = *impl_;
    if (I.current || I.queue->started() != I.chunk_count)
        throw Error(I.name + ": internal: " + std::to_string(I.queue->started()) + " of " +
                    std::to_string(I.chunk_count) + " chunks were given rows");
    I.queue->drain();
    I.queue->rethrow();
    if (I.queue->written() != I.chunk_count)
        throw Error(I.name + ": internal: " + std::to_string(I.queue->written()) + " of " +
                    std::to_string(I.chunk_count) + " chunks were written");
    exr_result_t rv = exr_finish(&I.ctxt);  // writes the offset table
    I.ctxt = nullptr;
    if (rv != EXR_ERR_SUCCESS) I.fail("cannot finish the file", rv);
    std::lock_guard<std::mutex> lock(I.mu);
    if (!I.io_error.empty()) throw Error(I.io_error);
}

SpectralExrWriter::Timing ExrCoreWriter::stats() const {
    SpectralExrWriter::Timing t = impl_->queue->timing();
    t.pack_seconds = impl_->pack_seconds;
    return t;
}

}  // namespace spectex
