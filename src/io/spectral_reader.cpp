#include "io/spectral_reader.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfTileDescription.h>
#include <fcntl.h>
#include <libdeflate.h>
#include <openexr.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "base/error.h"
#include "base/task_pool.h"
#include "io/exr_compression.h"
#include "io/exr_preflight.h"
#include "io/exr_zip.h"
#include "io/provenance_keys.h"
#include "spectral/expand.h"

namespace spectex {

AlphaKind alpha_kind(const SpectralExrInfo& info) {
    if (!info.alpha) return AlphaKind::None;
    for (const auto& [k, v] : info.attributes)
        if (k == provenance_key::kAlpha && v == to_string(AlphaKind::Unassociated))
            return AlphaKind::Unassociated;
    return AlphaKind::Associated;
}

// OpenEXR's InputFile decodes a chunk that holds less than its header's data window says (a window
// edited wider, a chunk swapped for a smaller one) without a word: the lines it lacks come back as
// zeros or as the previous chunk's bytes. So every chunk of level 0 a read touches is checked:
// a ZIP chunk (what spectex writes) must inflate to exactly the size the header gives it
// (libdeflate, which says when the stream ends short or runs over), an uncompressed one must have
// that size, and any other is decoded by OpenEXR's core library, which checks the size itself. A
// damaged chunk is an error naming its rows.
//
// A scanline file in ZIP, ZIPS or no compression with whole-resolution channels (every spectex
// bake without --mipmap) is then decoded here from the chunk just inflated, in parallel on the
// task pool: the predictor and the byte interleaving undone, each line's channels in the file's
// order, half and float samples converted to float. Every other file is checked (inflated once
// more) and read by InputFile. Measured with verify on 2 cores: a 2048x2048 default bake took
// 1.15 s through InputFile alone (unchecked) and 1.42 s checked and read by InputFile; decoded
// here, 0.60 s. The same bake with --mipmap (tiled: checked, then InputFile) takes 2.3-2.4 s with
// the check or without.
class ChunkReader {
  public:
    ChunkReader(const std::string& path, const Imf::Header& header) : path_(path) {
        exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
        init.error_handler_fn = exr_quiet_errors;
        exr_result_t r = exr_start_read(&ctx_, path_.c_str(), &init);
        if (r != EXR_ERR_SUCCESS) {
            ctx_ = nullptr;
            fail(r);
        }
        exr_storage_t storage = EXR_STORAGE_SCANLINE;
        exr_attr_box2i_t dw;
        r = exr_get_storage(ctx_, 0, &storage);
        if (r == EXR_ERR_SUCCESS) r = exr_get_data_window(ctx_, 0, &dw);
        if (r == EXR_ERR_SUCCESS && storage == EXR_STORAGE_TILED) {
            uint32_t tx = 0, ty = 0;
            exr_tile_level_mode_t mode;
            exr_tile_round_mode_t round;
            r = exr_get_tile_descriptor(ctx_, 0, &tx, &ty, &mode, &round);
            tiled_ = true;
            tile_w_ = static_cast<int>(std::max<uint32_t>(1, std::min<uint32_t>(tx, 1u << 30)));
            rows_ = static_cast<int>(std::max<uint32_t>(1, std::min<uint32_t>(ty, 1u << 30)));
        } else if (r == EXR_ERR_SUCCESS) {
            int32_t lines = 1;
            r = exr_get_scanlines_per_chunk(ctx_, 0, &lines);
            rows_ = std::max(1, lines);
        }
        if (r != EXR_ERR_SUCCESS) fail(r);
        y_min_ = dw.min.y;
        y_max_ = dw.max.y;
        fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd_ < 0) fail(EXR_ERR_FILE_ACCESS);
        columns_ = static_cast<int>((int64_t(dw.max.x) - dw.min.x + tile_w_) / tile_w_);
        checked_.assign(static_cast<size_t>((int64_t(dw.max.y) - dw.min.y + rows_) / rows_), 0);
        // What the direct decoder needs: the channels in file order, each line's bytes.
        width_ = static_cast<size_t>(int64_t(dw.max.x) - dw.min.x + 1);
        exr_compression_t compression = EXR_COMPRESSION_LAST_TYPE;
        direct_ = !tiled_ && exr_get_compression(ctx_, 0, &compression) == EXR_ERR_SUCCESS &&
                  (compression == EXR_COMPRESSION_ZIP || compression == EXR_COMPRESSION_ZIPS ||
                   compression == EXR_COMPRESSION_NONE);
        for (auto c = header.channels().begin(); c != header.channels().end() && direct_; ++c) {
            const Imf::Channel& ch = c.channel();
            const size_t bytes = ch.type == Imf::HALF ? 2 : 4;
            direct_ = ch.xSampling == 1 && ch.ySampling == 1 &&
                      (ch.type == Imf::HALF || ch.type == Imf::FLOAT || ch.type == Imf::UINT);
            channels_.push_back(
                {c.name(), ch.type == Imf::HALF, ch.type == Imf::UINT, line_bytes_});
            line_bytes_ += bytes * width_;
        }
    }

    // Decodes rows [y0, y0 + rows) of the data window (file coordinates) straight from the chunks
    // into `dest` (for each channel the file has, the float plane its rows go to, or null);
    // false when this file is not one the direct decoder takes (then nothing is written).
    bool decode(int y0, int rows, const std::map<std::string, float*>& dest) {
        if (!direct_) return false;
        struct Want {
            size_t offset;  // of the channel within a line
            bool half, uint;
            float* plane;
        };
        std::vector<Want> want;
        for (const ChannelLayout& c : channels_)
            if (auto it = dest.find(c.name); it != dest.end() && it->second)
                want.push_back({c.offset, c.half, c.uint, it->second});
        const int64_t first_chunk = (int64_t(y0) - y_min_) / rows_,
                      last_chunk = (int64_t(y0) + rows - 1 - y_min_) / rows_;
        std::vector<std::string> errors(static_cast<size_t>(last_chunk - first_chunk + 1));
        TaskPool::shared().parallel_for(errors.size(), hardware_threads(), [&](size_t i) {
            const int64_t c = first_chunk + static_cast<int64_t>(i);
            const int first = static_cast<int>(y_min_ + c * rows_);
            exr_chunk_info_t ci;
            const unsigned char* data = nullptr;
            errors[i] = inflate(exr_read_scanline_chunk_info(ctx_, 0, first, &ci), ci, true, &data);
            const size_t lines = static_cast<size_t>(std::min<int64_t>(rows_, y_max_ - first + 1));
            if (errors[i].empty() && ci.unpacked_size != lines * line_bytes_)
                errors[i] = "its size is not the window's";
            if (!errors[i].empty()) {
                errors[i] = damaged(first, errors[i]);
                return;
            }
            const size_t w = width_;
            for (size_t l = 0; l < lines; ++l) {
                const int64_t r = int64_t(first) + int64_t(l) - y0;  // row within the band
                if (r < 0 || r >= rows) continue;
                const unsigned char* line = data + l * line_bytes_;
                for (const Want& c : want) {
                    float* out = c.plane + static_cast<size_t>(r) * w;
                    const unsigned char* in = line + c.offset;
                    if (c.half) {
                        thread_local std::vector<uint16_t> h;
                        h.resize(w);
                        std::memcpy(h.data(), in, 2 * w);
                        half_to_floats(h.data(), out, w);
                    } else if (c.uint) {
                        for (size_t x = 0; x < w; ++x) {
                            uint32_t u;
                            std::memcpy(&u, in + 4 * x, 4);
                            out[x] = static_cast<float>(u);
                        }
                    } else {
                        std::memcpy(out, in, 4 * w);
                    }
                }
            }
        });
        for (const std::string& e : errors)
            if (!e.empty()) throw Error(e);
        return true;
    }
    ~ChunkReader() {
        if (ctx_) exr_finish(&ctx_);
        if (fd_ >= 0) ::close(fd_);
    }
    ChunkReader(const ChunkReader&) = delete;
    ChunkReader& operator=(const ChunkReader&) = delete;

    // Checks the chunks of rows [y0, y1] of the data window (file coordinates) that InputFile
    // will decode.
    void rows(int y0, int y1) {
        std::vector<std::pair<int, int>> todo;  // (tile column or -1, chunk row)
        for (int64_t c = (int64_t(y0) - y_min_) / rows_; c <= (int64_t(y1) - y_min_) / rows_; ++c) {
            if (c < 0 || c >= static_cast<int64_t>(checked_.size()) || checked_[size_t(c)])
                continue;
            if (tiled_)
                for (int tx = 0; tx < columns_; ++tx) todo.emplace_back(tx, static_cast<int>(c));
            else
                todo.emplace_back(-1, static_cast<int>(c));
            checked_[size_t(c)] = 1;
        }
        std::vector<std::string> errors(todo.size());
        TaskPool::shared().parallel_for(todo.size(), hardware_threads(), [&](size_t i) {
            const auto [tx, c] = todo[i];
            const int first = static_cast<int>(y_min_ + int64_t(c) * rows_);
            exr_chunk_info_t ci;
            const exr_result_t r = tx < 0 ? exr_read_scanline_chunk_info(ctx_, 0, first, &ci)
                                          : exr_read_tile_chunk_info(ctx_, 0, tx, c, 0, 0, &ci);
            errors[i] = check(r, ci);
            if (!errors[i].empty()) errors[i] = damaged(first, errors[i]);
        });
        for (const std::string& e : errors)
            if (!e.empty()) throw Error(e);
    }

  private:
    [[noreturn]] void fail(exr_result_t r) {
        if (ctx_) exr_finish(&ctx_);  // from the constructor: no destructor will
        ctx_ = nullptr;
        throw Error(path_ + ": cannot read the pixels: " + exr_get_default_error_message(r));
    }
    std::string damaged(int first, const std::string& why) const {
        return path_ + ": cannot read the pixels: the chunk of rows " + std::to_string(first) +
               "-" + std::to_string(std::min<int64_t>(first + int64_t(rows_) - 1, y_max_)) +
               " does not hold what the header says (" + why + "): a damaged file";
    }

    // "" when the chunk holds what the header says, else why not.
    std::string check(exr_result_t r, const exr_chunk_info_t& ci) const {
        if (r != EXR_ERR_SUCCESS) return exr_get_default_error_message(r);
        if (ci.compression == EXR_COMPRESSION_NONE || ci.compression == EXR_COMPRESSION_ZIP ||
            ci.compression == EXR_COMPRESSION_ZIPS) {
            const unsigned char* data = nullptr;
            return inflate(r, ci, false, &data);  // InputFile unpacks it
        }
        exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
        r = exr_decoding_initialize(ctx_, 0, &ci, &dec);
        if (r == EXR_ERR_SUCCESS) {
            // Nothing unpacked: the chunk is read and decompressed to the size it must have.
            for (int16_t k = 0; k < dec.channel_count; ++k) dec.channels[k].decode_to_ptr = nullptr;
            r = exr_decoding_choose_default_routines(ctx_, 0, &dec);
            if (r == EXR_ERR_SUCCESS) r = exr_decoding_run(ctx_, 0, &dec);
        }
        exr_decoding_destroy(ctx_, &dec);
        return r == EXR_ERR_SUCCESS ? "" : exr_get_default_error_message(r);
    }

    // A chunk stored without compression or in ZIP/ZIPS, read into this thread's scratch and
    // inflated to exactly its window's size. With `restore`, *data then points at its unpacked
    // bytes (lines one after another, each line's channels in file order), valid until this
    // thread's next call; without, the size alone is checked. "" when it holds what the header
    // says, else why not.
    std::string inflate(exr_result_t r, const exr_chunk_info_t& ci, bool restore,
                        const unsigned char** data) const {
        if (r != EXR_ERR_SUCCESS) return exr_get_default_error_message(r);
        const bool zip =
            ci.compression == EXR_COMPRESSION_ZIP || ci.compression == EXR_COMPRESSION_ZIPS;
        if (!zip && ci.packed_size != ci.unpacked_size) return "its size is not the window's";
        if (ci.packed_size > (1u << 30) || ci.unpacked_size > (1u << 30))
            return "a chunk over 1 GiB";
        // Per thread, kept between chunks (never zeroed: inflating writes every byte it reports,
        // and a short stream is an error whatever the buffer held).
        struct Scratch {
            std::unique_ptr<unsigned char[]> in, out, tmp;
            size_t in_size = 0, out_size = 0;
            libdeflate_decompressor* z = nullptr;
            ~Scratch() {
                if (z) libdeflate_free_decompressor(z);
            }
        };
        thread_local Scratch t;
        if (t.in_size < ci.packed_size) {
            t.in.reset(new unsigned char[ci.packed_size]);
            t.in_size = ci.packed_size;
        }
        if (t.out_size < ci.unpacked_size) {
            t.out.reset(new unsigned char[ci.unpacked_size]);
            t.tmp.reset(new unsigned char[ci.unpacked_size]);
            t.out_size = ci.unpacked_size;
        }
        if (!t.z && !(t.z = libdeflate_alloc_decompressor())) throw std::bad_alloc();
        if (::pread(fd_, t.in.get(), ci.packed_size, static_cast<off_t>(ci.data_offset)) !=
            static_cast<ssize_t>(ci.packed_size))
            return "the chunk runs past the end of the file";
        if (!zip || ci.packed_size == ci.unpacked_size) {  // stored as is (ZIP: not smaller)
            *data = t.in.get();
            return "";
        }
        if (libdeflate_zlib_decompress(t.z, t.in.get(), ci.packed_size, t.tmp.get(),
                                       ci.unpacked_size, nullptr) != LIBDEFLATE_SUCCESS)
            return "it does not inflate to the window's size";
        if (restore) {  // OpenEXR's ZIP pre-pass undone (io/exr_zip.h)
            zip_restore(t.tmp.get(), ci.unpacked_size, t.out.get());
            *data = t.out.get();
        }
        return "";
    }

    struct ChannelLayout {
        std::string name;
        bool half, uint;
        size_t offset;  // bytes from the start of a line
    };

    std::string path_;
    exr_context_t ctx_ = nullptr;
    int fd_ = -1;
    bool tiled_ = false;
    int y_min_ = 0, y_max_ = 0, rows_ = 1, tile_w_ = 1, columns_ = 1;
    std::vector<char> checked_;  // per chunk row of level 0
    bool direct_ = false;        // decode() takes this file
    size_t width_ = 0, line_bytes_ = 0;
    std::vector<ChannelLayout> channels_;  // in file order
};

struct SpectralReader::Impl {
    std::unique_ptr<Imf::InputFile> file;
    std::unique_ptr<ChunkReader> chunks;
};

SpectralReader::SpectralReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
    info_ = read_spectral_exr_info(path);  // throws "<path>: <cause>"
    alpha_ = alpha_kind(info_);
    try {
        exr_preflight(path);
        impl_->file = std::make_unique<Imf::InputFile>(path.c_str());
        impl_->chunks = std::make_unique<ChunkReader>(path, impl_->file->header());
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
    const Imath::Box2i dw = impl_->file->header().dataWindow();
    const size_t w = static_cast<size_t>(info_.width);
    std::map<std::string, float*> dest;
    for (size_t k = 0; k < info_.reflective.size(); ++k)
        dest[info_.reflective[k].channel] = planes + k * plane_stride;
    if (alpha && info_.alpha) dest["A"] = alpha;
    if (!impl_->chunks->decode(dw.min.y + y0, rows, dest))
        read_checked(y0, rows, planes, plane_stride, alpha);
    if (alpha && !info_.alpha) std::fill(alpha, alpha + w * static_cast<size_t>(rows), 1.0f);
}

// Any file the direct decoder does not take: its chunks checked, then read by InputFile.
void SpectralReader::read_checked(int y0, int rows, float* planes, size_t plane_stride,
                                  float* alpha) {
    const Imath::Box2i dw = impl_->file->header().dataWindow();
    const size_t w = static_cast<size_t>(info_.width);
    impl_->chunks->rows(dw.min.y + y0, dw.min.y + y0 + rows - 1);
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
