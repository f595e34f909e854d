#include "io/spectral_exr_writer.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <ImfTiledOutputFile.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "base/error.h"
#include "base/half.h"
#include "io/atomic_file.h"
#include "io/exr_core_writer.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

namespace {

// An Imf::OStream over a file descriptor (the AtomicFile's), buffered, with pwrite so that
// OpenEXR's seek back to the offset table works; errors carry errno (ENOSPC, EFBIG, ...).
class FdOStream : public Imf::OStream {
  public:
    FdOStream(int fd, const std::string& name) : Imf::OStream(name.c_str()), fd_(fd), name_(name) {
        buf_.reserve(kBufferSize);
    }
    void write(const char c[], int n) override {
        if (failed_) return;  // the first error is reported by finish()
        if (pos_ != buf_start_ + buf_.size()) {
            flush();
            buf_start_ = pos_;
        }
        buf_.insert(buf_.end(), c, c + n);
        pos_ += static_cast<uint64_t>(n);
        if (buf_.size() >= kBufferSize) flush();
    }
    uint64_t tellp() override { return pos_; }
    void seekp(uint64_t pos) override {
        if (!failed_) flush();
        pos_ = pos;
        buf_start_ = pos;
    }
    // Writes the buffer; the first failure is remembered and thrown (again by check()), and the
    // stream stays failed, so that OpenEXR's destructor, which swallows exceptions, cannot hide it.
    void flush() {
        if (failed_) throw Error(error_);
        size_t done = 0;
        while (done < buf_.size()) {
            ssize_t n = ::pwrite(fd_, buf_.data() + done, buf_.size() - done,
                                 static_cast<off_t>(buf_start_ + done));
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                failed_ = true;
                error_ = name_ + ": write failed: " + std::strerror(n < 0 ? errno : EIO);
                throw Error(error_);
            }
            done += static_cast<size_t>(n);
        }
        buf_start_ += buf_.size();
        buf_.clear();
    }

    void check() {
        flush();
        if (failed_) throw Error(error_);
    }

  private:
    static constexpr size_t kBufferSize = 4u << 20;
    bool failed_ = false;
    std::string error_;
    int fd_;
    std::string name_;
    uint64_t pos_ = 0, buf_start_ = 0;
    std::vector<char> buf_;
};

Imf::PixelType pixel_type(SampleType t) { return t == SampleType::Half ? Imf::HALF : Imf::FLOAT; }

}  // namespace

std::vector<std::pair<std::string, std::string>> texture_attributes(const SpectralExrLayout& L) {
    if (L.tile_width <= 0) {
        if (L.wrapmodes.empty()) return {};
        return {{"wrapmodes", L.wrapmodes}};
    }
    return {{"textureformat", "Plain Texture"},
            {"wrapmodes", L.wrapmodes.empty() ? std::string("black,black") : L.wrapmodes}};
}

struct SpectralExrWriter::Impl {
    SpectralExrLayout layout;
    std::unique_ptr<FdOStream> stream;
    std::unique_ptr<Imf::OutputFile> file;
    std::unique_ptr<Imf::TiledOutputFile> tiled;
    std::unique_ptr<ExrCoreWriter> core;
    std::vector<std::string> names;
    std::vector<uint16_t> half_scratch[4];  // A, R, G, B converted for half channels
    int next_row = 0;
};

SpectralExrWriter::SpectralExrWriter(AtomicFile& out, const SpectralExrLayout& layout)
    : impl_(std::make_unique<Impl>()) {
    impl_->layout = layout;
    const auto& L = layout;
    if (uses_core(L)) {
        impl_->core = std::make_unique<ExrCoreWriter>(out.fd(), out.final_path(), L);
        return;
    }
    Imath::Box2i data(Imath::V2i(L.x, L.y), Imath::V2i(L.x + L.width - 1, L.y + L.height - 1));
    Imath::Box2i display(Imath::V2i(L.full_x, L.full_y),
                         Imath::V2i(L.full_x + L.full_width - 1, L.full_y + L.full_height - 1));
    Imf::Header header(display, data, 1.0f, Imath::V2f(0, 0), 1.0f, Imf::INCREASING_Y,
                       static_cast<Imf::Compression>(L.compression.id));
    for (double l : L.lambda) {
        impl_->names.push_back(reflective_channel_name(l));
        header.channels().insert(impl_->names.back(), Imf::Channel(pixel_type(L.type)));
    }
    if (L.alpha) header.channels().insert("A", Imf::Channel(pixel_type(L.alpha_type)));
    if (L.preview) {
        for (const char* c : {"R", "G", "B"})
            header.channels().insert(c, Imf::Channel(pixel_type(L.type)));
        // The preview channels are linear Rec.709 / sRGB primaries, D65 white.
        Imf::addChromaticities(header, Imf::Chromaticities());
    }
    header.insert("spectralLayoutVersion", Imf::StringAttribute("1.0"));
    header.zipCompressionLevel() = std::min(L.zip_level, 9);  // zlib stops at 9; libdeflate at 12
    for (const auto& [k, v] : L.attributes) header.insert(k, Imf::StringAttribute(v));
    for (const auto& [k, v] : texture_attributes(L)) header.insert(k, Imf::StringAttribute(v));
    impl_->stream = std::make_unique<FdOStream>(out.fd(), out.final_path());
    if (L.tile_width > 0) {
        header.setTileDescription(Imf::TileDescription(
            static_cast<unsigned>(L.tile_width), static_cast<unsigned>(L.tile_height),
            L.mipmap ? Imf::MIPMAP_LEVELS : Imf::ONE_LEVEL, Imf::ROUND_DOWN));
        impl_->tiled =
            std::make_unique<Imf::TiledOutputFile>(*impl_->stream, header, std::max(1, L.threads));
    } else {
        impl_->file =
            std::make_unique<Imf::OutputFile>(*impl_->stream, header, std::max(1, L.threads));
    }
}

bool SpectralExrWriter::uses_core(const SpectralExrLayout& L) {
    std::string kind = L.writer;
    if (kind == "auto") {
        const char* e = std::getenv("SPECTEX_EXR_WRITER");
        kind = e && *e ? e : "core";
    }
    if (kind != "core" && kind != "imf")
        throw Error("unknown EXR writer '" + kind + "' (known: core, imf)");
    return kind == "core" && L.compression.core_writer;
}

int SpectralExrWriter::levels() const {
    if (impl_->core) return impl_->core->levels();
    return impl_->tiled ? impl_->tiled->numLevels() : 1;
}
int SpectralExrWriter::level_width(int level) const {
    if (impl_->core) return impl_->core->level_width(level);
    return impl_->tiled ? impl_->tiled->levelWidth(level) : impl_->layout.width;
}
int SpectralExrWriter::level_height(int level) const {
    if (impl_->core) return impl_->core->level_height(level);
    return impl_->tiled ? impl_->tiled->levelHeight(level) : impl_->layout.height;
}

SpectralExrWriter::~SpectralExrWriter() = default;

void SpectralExrWriter::write_rows(int rows, const void* spectral, size_t plane_stride,
                                   const float* alpha, const float* pr, const float* pg,
                                   const float* pb) {
    if (impl_->core)
        impl_->core->write_rows(rows, spectral, plane_stride, alpha, pr, pg, pb);
    else
        write_level_rows(0, impl_->next_row, rows, spectral, plane_stride, alpha, pr, pg, pb);
    impl_->next_row += rows;
}

void SpectralExrWriter::write_level_rows(int level, int row0, int rows, const void* spectral,
                                         size_t plane_stride, const float* alpha, const float* pr,
                                         const float* pg, const float* pb) {
    if (impl_->core) {
        impl_->core->write_level_rows(level, row0, rows, spectral, plane_stride, alpha, pr, pg, pb);
        return;
    }
    const auto& L = impl_->layout;
    const size_t w = static_cast<size_t>(level_width(level));
    const int y0 = L.y + row0;
    // Slice bases are addressed with absolute (x, y): shift by the strip's origin.
    const ptrdiff_t origin = static_cast<ptrdiff_t>(y0) * static_cast<ptrdiff_t>(w) + L.x;
    Imf::FrameBuffer fb;
    const size_t es = L.type == SampleType::Half ? 2 : 4;
    for (size_t k = 0; k < impl_->names.size(); ++k) {
        const char* base = static_cast<const char*>(spectral) + k * plane_stride * es;
        fb.insert(
            impl_->names[k],
            Imf::Slice(pixel_type(L.type),
                       const_cast<char*>(base - origin * static_cast<ptrdiff_t>(es)), es, es * w));
    }
    // OpenEXR's writer does not convert between pixel types: half channels get half data.
    const size_t n = w * static_cast<size_t>(rows);
    auto insert_float = [&](const char* name, const float* p, SampleType type, int scratch) {
        if (type == SampleType::Float) {
            fb.insert(name, Imf::Slice(Imf::FLOAT,
                                       reinterpret_cast<char*>(const_cast<float*>(p) - origin),
                                       sizeof(float), sizeof(float) * w));
            return;
        }
        auto& h = impl_->half_scratch[scratch];
        h.resize(n);
        for (size_t i = 0; i < n; ++i) h[i] = float_to_half(p[i]);
        fb.insert(name,
                  Imf::Slice(Imf::HALF, reinterpret_cast<char*>(h.data() - origin), 2, 2 * w));
    };
    if (L.alpha) insert_float("A", alpha, L.alpha_type, 0);
    if (L.preview) {
        insert_float("R", pr, L.type, 1);
        insert_float("G", pg, L.type, 2);
        insert_float("B", pb, L.type, 3);
    }
    if (impl_->tiled) {
        Imf::TiledOutputFile& t = *impl_->tiled;
        t.setFrameBuffer(fb);
        const int ty0 = row0 / L.tile_height;
        const int ty1 = (row0 + rows - 1) / L.tile_height;
        t.writeTiles(0, t.numXTiles(level) - 1, ty0, ty1, level, level);
    } else {
        impl_->file->setFrameBuffer(fb);
        impl_->file->writePixels(rows);
    }
}

void SpectralExrWriter::finish() {
    if (impl_->core) {
        impl_->core->finish();
        return;
    }
    impl_->file.reset();  // writes the line offset table (its destructor swallows errors)
    impl_->tiled.reset();
    impl_->stream->check();
}

const char* SpectralExrWriter::writer_name() const { return impl_->core ? "core" : "imf"; }

SpectralExrWriter::Timing SpectralExrWriter::timing() const {
    return impl_->core ? impl_->core->stats() : Timing{};
}

}  // namespace spectex
