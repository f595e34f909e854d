// OpenImageIO's side of ImageSource (io/image_source.h), PNG writing for render and the code
// floats of the linearizer's table: the image module (io/image_library.h).
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <mutex>

#include "base/bounded_read.h"
#include "base/error.h"
#include "base/text.h"
#include "io/icc_profile.h"
#include "io/image_source.h"
#include "io/oiio/oiio_library.h"

namespace spectex {

namespace {

// The reader's view of the checked file: OIIO reads through this descriptor (never the path again,
// so the file read is the file checked) and every byte read at the hash's frontier extends the
// FNV-1a of the file, so the content hash costs no read of its own. Readers may read from several
// threads (OpenEXR) and out of order (TIFF directories, EXR offset tables): only bytes that
// continue the hash in file order are hashed; the rest is read at the end (content_hash).
class HashingProxy final : public OIIO::Filesystem::IOProxy {
  public:
    HashingProxy(const std::string& path, int fd, uint64_t size)
        : IOProxy(path, IOProxy::Read), fd_(fd), size_(size) {}
    const char* proxytype() const override { return "spectex-hashing"; }
    size_t read(void* buf, size_t size) override {
        const size_t n = pread(buf, size, m_pos);
        m_pos += static_cast<int64_t>(n);
        return n;
    }
    size_t pread(void* buf, size_t size, int64_t offset) override {
        if (offset < 0) return 0;
        size_t done = 0;
        while (done < size) {
            const ssize_t got = ::pread(fd_, static_cast<char*>(buf) + done, size - done,
                                        static_cast<off_t>(offset) + static_cast<off_t>(done));
            if (got < 0 && errno == EINTR) continue;
            if (got <= 0) break;
            done += static_cast<size_t>(got);
        }
        observe(static_cast<const unsigned char*>(buf), done, static_cast<uint64_t>(offset));
        return done;
    }
    bool seek(int64_t offset) override {
        if (offset < 0) return false;
        m_pos = offset;
        return true;
    }
    size_t size() const override { return static_cast<size_t>(size_); }
    size_t write(const void*, size_t) override { return 0; }
    size_t pwrite(const void*, size_t, int64_t) override { return 0; }

    // The hash of the whole file: what the decoder left is read now.
    std::string finish(const std::string& path) {
        std::lock_guard<std::mutex> lock(mutex_);
        hash_file_range(fd_, frontier_, size_, hash_, path);
        frontier_ = size_;
        return hash_.text();
    }

  private:
    void observe(const unsigned char* p, size_t n, uint64_t offset) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (offset > frontier_ || offset + n <= frontier_ || frontier_ >= size_) return;
        const uint64_t end = std::min<uint64_t>(offset + n, size_);
        hash_.add(p + (frontier_ - offset), static_cast<size_t>(end - frontier_));
        frontier_ = end;
    }
    int fd_;
    uint64_t size_;
    std::mutex mutex_;
    uint64_t frontier_ = 0;  // bytes [0, frontier_) are in hash_
    Fnv1a64 hash_;
};

}  // namespace

class OiioImageSource final : public ImageSource {
  public:
    static std::unique_ptr<ImageSource> open(const std::string& path, uint64_t max_pixels);
    ~OiioImageSource() override {
        if (in) in->close();
    }
    std::string content_hash() override {
        return !whole_hash.empty() ? whole_hash : proxy->finish(info_.path);
    }
    void read_rgba(int y0, int y1, float* rgba) override;

  private:
    // The steps of open(): the reader named by the file's first bytes or its name; a JPEG read
    // into memory; what the opened image is (windows, type, colour tags, channels, levels).
    static std::string choose_format(const CheckedFile& f, const std::string& path,
                                     std::vector<std::string>& png_colour_chunks);
    void read_whole_file(const std::string& path);
    void describe(const OIIO::ImageSpec& spec, uint64_t max_pixels,
                  const std::vector<std::string>& png_colour_chunks);
    void choose_channels(const OIIO::ImageSpec& spec);
    void count_levels();

    std::unique_ptr<CheckedFile> file;    // the descriptor checked, open while the image is read
    std::unique_ptr<HashingProxy> proxy;  // before `in`: destroyed after it
    std::vector<unsigned char> bytes;     // JPEG: the file, read once (see open)
    std::unique_ptr<OIIO::Filesystem::IOMemReader> memory;
    std::string whole_hash;  // JPEG: the hash of `bytes`
    std::unique_ptr<OIIO::ImageInput> in;
    int chbegin = 0, chend = 0;         // the channels read: [chbegin, chend) of the file
    int color_channels[3] = {0, 0, 0};  // relative to chbegin
    int alpha = -1;                     // relative to chbegin, -1 when none
    bool tiled = false;
    int tile_height = 0;
    // Tiled inputs: a band of whole tile rows, rows [band_y0, band_y1) of the image (0-based),
    // read by read_tiles and kept for the next request that falls in it.
    std::vector<float> band;
    int band_y0 = 0, band_y1 = 0;
    std::vector<float> scratch_;
};

namespace {

std::string oiio_error(OIIO::ImageInput* in) {
    std::string e = in ? in->geterror() : OIIO::geterror();
    while (!e.empty() && (e.back() == '\n' || e.back() == ' ')) e.pop_back();
    for (char& c : e)
        if (c == '\n' || c == '\r') c = ' ';  // one line: some readers report several errors
    return e.empty() ? "unknown OpenImageIO error" : e;
}

// "R, G, B, Z" or, for long lists, the first ten then "... (1000 channels)".
std::string channel_list(const std::vector<std::string>& names) {
    std::string out;
    const size_t shown = names.size() > 12 ? 10 : names.size();
    for (size_t i = 0; i < shown; ++i) out += (i ? ", " : "") + printable_excerpt(names[i], 64);
    if (shown < names.size()) out += ", ... (" + std::to_string(names.size()) + " channels)";
    return out.empty() ? "no channels" : out;
}

// PNG: the chunks must run to an IEND chunk inside the file. libpng stops once it has the rows it
// needs, so a file cut in its last IDAT's checksum or in IEND would otherwise read as whole. Reads
// 8 bytes per chunk. Returns the colour chunks the file has (sRGB, gAMA, iCCP, cHRM), in order:
// OpenImageIO reports an untagged PNG as sRGB too, so only they say whether the file states it.
std::vector<std::string> check_png_chunks(const CheckedFile& f, const std::string& path) {
    std::vector<std::string> colour;
    unsigned char sig[8];
    if (::pread(f.fd(), sig, 8, 0) != 8) throw Error(path + ": truncated PNG (no signature)");
    uint64_t pos = 8;
    for (;;) {
        unsigned char h[8];
        ssize_t n = ::pread(f.fd(), h, 8, static_cast<off_t>(pos));
        if (n != 8)
            throw Error(path + ": truncated PNG: the file ends at byte " +
                        std::to_string(f.size()) + " without an IEND chunk");
        const uint64_t len =
            (uint64_t{h[0]} << 24) | (uint64_t{h[1]} << 16) | (uint64_t{h[2]} << 8) | h[3];
        const std::string type(reinterpret_cast<const char*>(h + 4), 4);
        if (pos + 12 + len > f.size())
            throw Error(path + ": truncated PNG: chunk '" + printable_excerpt(type, 64) +
                        "' at byte " + std::to_string(pos) + " runs past the end of the file (" +
                        std::to_string(f.size()) + " bytes)");
        if (type == "IEND") return colour;
        if (type == "sRGB" || type == "gAMA" || type == "iCCP" || type == "cHRM")
            colour.push_back(type);
        pos += 12 + len;
    }
}

struct ChannelChoice {
    int colour[3] = {-1, -1, -1};
    int alpha = -1;
    std::string note;
};

// OpenEXR names its channels: choose them by name, never by position (a spectral, polarised or
// depth channel is not a colour, and Z is not alpha).
//   1. R, G, B;  2. Y (grey);  3. one layer's <layer>.R/.G/.B, the first layer in name order, with
//   a note;  4. a layer's <layer>.Y.  Alpha only from a channel named A or alpha (any case), the
//   chosen layer's own first. Anything else: refused, listing what the file has.
ChannelChoice choose_by_name(const std::vector<std::string>& names, const std::string& path) {
    auto find = [&](const std::string& n) -> int {
        for (size_t i = 0; i < names.size(); ++i)
            if (names[i] == n) return static_cast<int>(i);
        return -1;
    };
    auto find_alpha = [&](const std::string& prefix) -> int {
        for (size_t i = 0; i < names.size(); ++i) {
            const std::string& n = names[i];
            if (n.size() <= prefix.size() || n.compare(0, prefix.size(), prefix) != 0) continue;
            const std::string rest = lower_ascii(n.substr(prefix.size()));
            if (rest == "a" || rest == "alpha") return static_cast<int>(i);
        }
        return -1;
    };
    ChannelChoice c;
    if (int r = find("R"), g = find("G"), b = find("B"); r >= 0 && g >= 0 && b >= 0) {
        c.colour[0] = r, c.colour[1] = g, c.colour[2] = b;
        c.alpha = find_alpha("");
        return c;
    }
    if (int y = find("Y"); y >= 0) {
        // Y with RY and BY is OpenEXR's luminance/chroma encoding, not grey: baking Y alone would
        // drop the colour without a word.
        if (find("RY") >= 0 || find("BY") >= 0)
            throw Error(path +
                        ": luminance/chroma channels (Y, RY, BY) are not supported: write the file "
                        "with R, G, B");
        c.colour[0] = c.colour[1] = c.colour[2] = y;
        c.alpha = find_alpha("");
        return c;
    }
    // Layers, in name order (deterministic whatever the file's channel order).
    std::vector<std::string> layers;
    for (const auto& n : names) {
        size_t dot = n.find_last_of('.');
        if (dot != std::string::npos && dot > 0) layers.push_back(n.substr(0, dot));
    }
    std::sort(layers.begin(), layers.end());
    layers.erase(std::unique(layers.begin(), layers.end()), layers.end());
    auto use_layer_alpha = [&](const std::string& layer) {
        c.alpha = find_alpha(layer + ".");
        if (c.alpha < 0) {
            // A top-level A/alpha (no dot) goes with any layer.
            for (size_t i = 0; i < names.size(); ++i) {
                const std::string l = lower_ascii(names[i]);
                if (l == "a" || l == "alpha") c.alpha = static_cast<int>(i);
            }
        }
    };
    for (const auto& layer : layers) {
        int r = find(layer + ".R"), g = find(layer + ".G"), b = find(layer + ".B");
        if (r < 0 || g < 0 || b < 0) continue;
        c.colour[0] = r, c.colour[1] = g, c.colour[2] = b;
        use_layer_alpha(layer);
        c.note =
            "input has no R, G, B channels: used layer '" + printable_excerpt(layer, 64) + "' (" +
            printable_excerpt(layer, 64) + ".R, .G, .B" +
            (c.alpha >= 0 ? ", alpha " + printable_excerpt(names[static_cast<size_t>(c.alpha)], 64)
                          : "") +
            ")";
        return c;
    }
    for (const auto& layer : layers) {
        int y = find(layer + ".Y");
        if (y < 0) continue;
        c.colour[0] = c.colour[1] = c.colour[2] = y;
        use_layer_alpha(layer);
        c.note =
            "input has no R, G, B or Y channels: used layer '" + printable_excerpt(layer, 64) +
            "' (" + printable_excerpt(layer, 64) + ".Y as grey" +
            (c.alpha >= 0 ? ", alpha " + printable_excerpt(names[static_cast<size_t>(c.alpha)], 64)
                          : "") +
            ")";
        return c;
    }
    throw Error(path +
                ": no colour channels (R, G, B or Y, or a layer's <layer>.R/.G/.B or <layer>.Y); "
                "the file has " +
                channel_list(names));
}

// Formats without channel names (PNG, JPEG, TIFF, ...): OpenImageIO calls them Y / Y,A / R,G,B /
// R,G,B,A (2-channel TIFF and TGA read as "R,G", still grey + alpha) by position.
ChannelChoice choose_by_position(const OIIO::ImageSpec& spec) {
    ChannelChoice c;
    int alpha = spec.alpha_channel;
    // A reader's alpha index past the last channel is not an alpha channel: OpenImageIO 2.4's GIF
    // reader gives 4 for its 4 channels, and taking it read a fifth channel, shifting every
    // pixel's channels by one.
    if (alpha >= spec.nchannels) alpha = -1;
    if (alpha < 0 && spec.nchannels == 2) alpha = 1;
    if (alpha < 0 && spec.nchannels >= 4) alpha = 3;
    if (spec.nchannels == 1) alpha = -1;  // a lone channel is the image, never alpha over nothing
    std::vector<int> colour;
    for (int i = 0; i < spec.nchannels && colour.size() < 3; ++i)
        if (i != alpha) colour.push_back(i);
    if (colour.size() == 1 || colour.size() == 2) colour.resize(1);
    if (colour.size() == 1) colour = {colour[0], colour[0], colour[0]};
    for (int i = 0; i < 3; ++i) c.colour[i] = colour[static_cast<size_t>(i)];
    c.alpha = alpha;
    return c;
}

// The OIIO reader a file's first bytes name (magic numbers of the formats textures come in); ""
// when they name none (TGA has no signature: its extension decides).
std::string format_from_signature(const unsigned char* b, size_t n) {
    auto is = [&](const char* magic, size_t len, size_t at = 0) {
        return n >= at + len && std::memcmp(b + at, magic, len) == 0;
    };
    if (is("\x89PNG\r\n\x1a\n", 8)) return "png";
    if (is("\xff\xd8\xff", 3)) return "jpeg";
    if (is("II*\0", 4) || is("MM\0*", 4) || is("II+\0", 4) || is("MM\0+", 4)) return "tiff";
    if (is("\x76\x2f\x31\x01", 4)) return "openexr";
    if (is("BM", 2)) return "bmp";
    if (is("#?RADIANCE", 10) || is("#?RGBE", 6)) return "hdr";
    if (is("GIF87a", 6) || is("GIF89a", 6)) return "gif";
    if (is("RIFF", 4) && is("WEBP", 4, 8)) return "webp";
    if (is("8BPS", 4)) return "psd";
    if (is("SDPX", 4) || is("XPDS", 4)) return "dpx";
    if (is("\x80\x2a\x5f\xd7", 4)) return "cineon";
    if (is("\0\0\0\x0cjP  ", 8) || is("\xff\x4f\xff\x51", 4)) return "jpeg2000";
    if (is("DDS ", 4)) return "dds";
    if (is("FOR4", 4) && is("CIMG", 4, 8)) return "iff";
    if (is("SIMPLE  =", 9)) return "fits";
    if (is("\x53\x80\xf6\x34", 4)) return "pic";
    if (is("ftyp", 4, 4) &&
        (is("heic", 4, 8) || is("heix", 4, 8) || is("mif1", 4, 8) || is("avif", 4, 8)))
        return "heif";
    if (n >= 2 && b[0] == 'P' && b[1] >= '1' && b[1] <= '7') return "pnm";
    return "";
}

// What the file says of its colour. OpenImageIO fills oiio:ColorSpace with a default for some
// formats whatever the file holds: the hint counts as stated only when something in the file says
// it (for PNG its chunks, for JPEG, GIF and WebP the Exif ColorSpace tag; OpenEXR's "Linear" and
// HDR's "linear" are the reader's own).
ColourTags colour_tags(const OIIO::ImageSpec& spec, const std::string& format,
                       const std::vector<std::string>& png_chunks) {
    ColourTags t;
    t.format = format;
    t.hint = spec.get_string_attribute("oiio:ColorSpace");
    auto has_chunk = [&](const char* c) {
        return std::find(png_chunks.begin(), png_chunks.end(), c) != png_chunks.end();
    };
    if (t.hint.empty()) {
    } else if (format == "png") {
        t.hint_from = has_chunk("sRGB") ? "sRGB chunk" : has_chunk("gAMA") ? "gAMA chunk" : "";
    } else if (format == "jpeg" || format == "gif" || format == "webp") {
        if (spec.get_int_attribute("Exif:ColorSpace", 0) == 1 && lower_ascii(t.hint) == "srgb")
            t.hint_from = "Exif ColorSpace";
    } else if (format == "openexr") {
        if (lower_ascii(t.hint) != "linear") t.hint_from = "OpenEXR header";
    } else if (format == "dpx") {
        t.hint_from = "DPX transfer";
    } else if (format == "tiff") {
        t.hint_from = "TIFF metadata";
    }
    // Any other reader's value (HDR's "linear", PNM's "Rec709", ...) is its assumption for the
    // format, not something the file says.
    if (const OIIO::ParamValue* p = spec.find_attribute("ICCProfile");
        p && p->type().basetype == OIIO::TypeDesc::UINT8 && p->datasize() > 0) {
        const auto* b = static_cast<const unsigned char*>(p->data());
        t.icc.assign(b, b + p->datasize());
    }
    t.icc_refused = t.icc.empty() && has_chunk("iCCP");
    if (const OIIO::ParamValue* p = spec.find_attribute("chromaticities");
        p && p->type().basetype == OIIO::TypeDesc::FLOAT &&
        p->type().numelements() * p->type().aggregate == 8) {
        const auto* f = static_cast<const float*>(p->data());
        t.chromaticities.assign(f, f + 8);
    }
    return t;
}

}  // namespace

std::string OiioImageSource::choose_format(const CheckedFile& f, const std::string& path,
                                           std::vector<std::string>& png_colour_chunks) {
    if (f.size() == 0) throw Error(path + ": empty file");
    std::string format;  // the reader chosen by the file's first bytes, "" when they say nothing
    unsigned char sig[16] = {0};
    const ssize_t got = ::pread(f.fd(), sig, sizeof sig, 0);
    if (got == 16 && std::memcmp(sig, "\x89PNG\r\n\x1a\n", 8) == 0)
        png_colour_chunks = check_png_chunks(f, path);
    if (got > 0) format = format_from_signature(sig, static_cast<size_t>(got));
    // One reader only: the one the content names, else the one the extension names. OIIO's own open
    // tries every reader when the first fails, and some read a whole large file to say no (a
    // 200 MB file of zeros named .png took 20 s): a file neither names is refused at once.
    if (format.empty()) {
        const size_t dot = path.find_last_of('.'), slash = path.find_last_of('/');
        if (dot != std::string::npos && (slash == std::string::npos || dot > slash))
            format = lower_ascii(path.substr(dot + 1));
    }
    if (format.empty())
        throw Error(path +
                    ": cannot read: neither its contents nor its name (no extension) say what "
                    "image format it is");
    // OpenImageIO 2.4's Maya IFF reader expands run-length data without checking it against its
    // buffers: one damaged byte freed memory twice (a crash) or, in a batch, silently corrupted the
    // heap the other files were baked with. No file of a format whose reader can do that is opened.
    if (format == "iff" || format == "z")
        throw Error(path +
                    ": Maya IFF is not read: OpenImageIO's IFF reader does not check its "
                    "run-length data, and a damaged file corrupts memory; convert it to EXR, TIFF "
                    "or PNG first");
    return format;
}

// OIIO 2.4's JPEG reader takes only in-memory proxies: a JPEG (small next to its pixels) is read
// once into memory and hashed there.
void OiioImageSource::read_whole_file(const std::string& path) {
    bytes.resize(static_cast<size_t>(file->size()));
    size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t got =
            ::pread(file->fd(), bytes.data() + done, bytes.size() - done, static_cast<off_t>(done));
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0)
            throw Error(path + ": read error: " +
                        (got < 0 ? std::strerror(errno) : "the file became shorter"));
        done += static_cast<size_t>(got);
    }
    Fnv1a64 h;
    h.add(bytes.data(), bytes.size());
    whole_hash = h.text();
    memory = std::make_unique<OIIO::Filesystem::IOMemReader>(bytes.data(), bytes.size());
}

void OiioImageSource::describe(const OIIO::ImageSpec& spec, uint64_t max_pixels,
                               const std::vector<std::string>& png_colour_chunks) {
    SourceInfo& info = info_;
    const std::string& path = info.path;
    info.format_name = in->format_name();
    static_cast<PixelWindows&>(info) = {spec.x,          spec.y,          spec.width,
                                        spec.height,     spec.full_x,     spec.full_y,
                                        spec.full_width, spec.full_height};
    info.channels = spec.nchannels;
    if (spec.width <= 0 || spec.height <= 0) throw Error(path + ": image has no pixels");
    if (spec.depth > 1)
        throw Error(path + ": volume images (depth " + std::to_string(spec.depth) +
                    ") are not supported");
    if (spec.deep) throw Error(path + ": deep images are not supported");
    uint64_t pixels = static_cast<uint64_t>(spec.width) * static_cast<uint64_t>(spec.height);
    if (pixels > max_pixels)
        throw Error(path + ": " + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                    " pixels exceed the limit of " + std::to_string(max_pixels) +
                    " (--max-pixels)");
    if (spec.nchannels < 1) throw Error(path + ": image has no channels");

    info.is_float = spec.format.basetype == OIIO::TypeDesc::FLOAT ||
                    spec.format.basetype == OIIO::TypeDesc::HALF ||
                    spec.format.basetype == OIIO::TypeDesc::DOUBLE;
    info.bits = static_cast<int>(spec.format.size() * 8);
    if (int b = spec.get_int_attribute("oiio:BitsPerSample", 0); b > 0 && !info.is_float)
        info.bits = b;
    info.colour = colour_tags(spec, info.format_name, png_colour_chunks);
    // A profile whose tags lie about where they are is damage, as a chunk past the file's end is:
    // refused (the decoder, io/oiio/icc_decoder_oiio.cpp, has already declined to read it).
    if (!info.colour.icc.empty()) {
        const IccStructure icc =
            check_icc_structure(info.colour.icc.data(), info.colour.icc.size());
        if (!icc.damage.empty()) throw Error(path + ": ICC profile: " + icc.damage);
    }
    choose_channels(spec);
    tiled = spec.tile_width > 0;
    tile_height = spec.tile_height;
}

// Channels: by name where the format has names (OpenEXR), else by position.
void OiioImageSource::choose_channels(const OIIO::ImageSpec& spec) {
    SourceInfo& info = info_;
    // Ink separations (a CMYK TIFF: OpenImageIO names its channels ink0..ink3 and converts
    // nothing): read by position they were taken as R, G, B and A, black ink as alpha. Their
    // colour depends on the inks and the press; spectex reads RGB only.
    const int photometric = spec.get_int_attribute("tiff:PhotometricInterpretation", -1);
    const bool inks = std::any_of(spec.channelnames.begin(), spec.channelnames.end(),
                                  [](const std::string& n) { return n.rfind("ink", 0) == 0; });
    if (photometric == 5 || inks)
        throw Error(info.path + ": ink separations (CMYK" +
                    (spec.nchannels != 4 ? ", " + std::to_string(spec.nchannels) + " inks" : "") +
                    "): spectex reads RGB; convert the file to RGB with its ICC profile first");
    const ChannelChoice choice = info.format_name == "openexr"
                                     ? choose_by_name(spec.channelnames, info.path)
                                     : choose_by_position(spec);
    if (!choice.note.empty()) info.notes.push_back(choice.note);
    for (int i = 0; i < 4; ++i) {
        const int c = i < 3 ? choice.colour[i] : choice.alpha;
        if (c >= spec.nchannels || c < (i < 3 ? 0 : -1))
            throw Error(info.path + ": the reader named channel " + std::to_string(c) + " of " +
                        std::to_string(spec.nchannels));
    }
    // Only the span of channels in use is read (a 1000-channel file is not decoded whole).
    int lo = choice.colour[0], hi = choice.colour[0];
    for (int c : {choice.colour[1], choice.colour[2], choice.alpha})
        if (c >= 0) lo = std::min(lo, c), hi = std::max(hi, c);
    chbegin = lo;
    chend = hi + 1;
    for (int i = 0; i < 3; ++i) color_channels[i] = choice.colour[i] - lo;
    alpha = choice.alpha >= 0 ? choice.alpha - lo : -1;
    info.alpha_channel = choice.alpha;
    if (choice.alpha >= 0)
        info.alpha = spec.get_int_attribute("oiio:UnassociatedAlpha", 0) ? AlphaKind::Unassociated
                                                                         : AlphaKind::Associated;
}

void OiioImageSource::count_levels() {
    SourceInfo& info = info_;
    info.miplevels = 1;
    while (in->seek_subimage(0, info.miplevels)) ++info.miplevels;
    info.subimages = 1;
    // Probing one frame past the last leaves OpenImageIO 2.4's WebP reader unable to decode its
    // first ("Couldn't decode subimage 0": no WebP could be read), and its readers do not say which
    // hold several (supports("multiimage") is false for TIFF and OpenEXR too): a WebP's frames
    // beyond the first, never read, are not counted.
    if (std::string(in->format_name()) != "webp")
        while (in->seek_subimage(info.subimages, 0)) ++info.subimages;
    if (!in->seek_subimage(0, 0)) throw Error(info.path + ": " + oiio_error(in.get()));
    (void)in->geterror();  // counting levels probed one past the last: forget that error
}

std::unique_ptr<ImageSource> OiioImageSource::open(const std::string& path, uint64_t max_pixels) {
    // A regular file, checked before any library opens it: a FIFO, device or folder is refused
    // at once (OIIO would block on a FIFO, or read /dev/zero forever).
    std::unique_ptr<OiioImageSource> src(new OiioImageSource);
    src->info_.path = path;
    src->file = std::make_unique<CheckedFile>(path, file_limits::kImage, "an input image");
    struct stat fst;
    if (::fstat(src->file->fd(), &fst) != 0)
        throw Error(path + ": cannot stat: " + std::strerror(errno));
    src->identity_ = SourceIdentity::of(fst);
    std::vector<std::string> png_colour_chunks;
    const std::string format = choose_format(*src->file, path, png_colour_chunks);

    // Unassociated alpha as stored: OIIO would otherwise premultiply PNG alpha on gamma-encoded
    // 8-bit values, before we linearise.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    // Readers that can read through a proxy read the checked descriptor and hash as they go;
    // the others (a few rare formats) open the path, and the hash reads the file at the end.
    // (By name, with no config: OIIO 2.4's create() given a path or a config opens the file itself
    // and falls back to every other reader.) The proxy is a member declared before the reader, so
    // that it outlives it.
    src->proxy = std::make_unique<HashingProxy>(path, src->file->fd(), src->file->size());
    auto in = OIIO::ImageInput::create(format, false, static_cast<const OIIO::ImageSpec*>(nullptr));
    if (!in) throw Error(path + ": cannot read: " + oiio_error(nullptr));
    if (in->supports("ioproxy")) {
        OIIO::Filesystem::IOProxy* p = src->proxy.get();
        if (std::string(in->format_name()) == "jpeg") {
            // Past 256 MiB the JPEG reader opens the path itself and the hash reads the file at
            // the end.
            p = nullptr;
            if (src->file->size() <= (uint64_t{256} << 20)) {
                src->read_whole_file(path);
                p = src->memory.get();
            }
        }
        if (p) config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &p);
    }
    {
        OIIO::ImageSpec opened;
        if (!in->open(path, opened, config)) {
            std::string why = oiio_error(in.get());
            if (why.empty()) why = "not a " + format + " file";
            throw Error(path + ": cannot read: " + why);
        }
    }
    // Some readers report damage found while opening (libjpeg's "Premature end of JPEG file" on a
    // truncated progressive JPEG, whose scans are read at once) as an error but still open.
    if (in->has_error()) throw Error(path + ": cannot read: " + oiio_error(in.get()));
    src->in = std::move(in);
    src->describe(src->in->spec(), max_pixels, png_colour_chunks);
    src->count_levels();
    return src;
}

void OiioImageSource::read_rgba(int y0, int y1, float* rgba) {
    OiioImageSource& I = *this;
    const int nch = I.chend - I.chbegin;
    const size_t w = static_cast<size_t>(info_.width);
    const size_t rows = static_cast<size_t>(y1 - y0);
    OIIO::ImageInput* in = I.in.get();
    const float* s;
    if (I.tiled) {
        // OIIO 2.4's read_scanlines divides by zero on tiled TIFFs when it converts types: tiled
        // inputs are read by whole tile rows covering the request, never the whole image at once
        // (a 500-byte tiled TIFF claiming 16000x16000 pixels had 4 GB allocated before its first
        // tile was found broken).
        if (y0 < I.band_y0 || y1 > I.band_y1) {
            const int th = std::max(1, I.tile_height);
            const int b0 = y0 / th * th;
            const int b1 = std::min(info_.height, (y1 + th - 1) / th * th);
            I.band.resize(w * static_cast<size_t>(b1 - b0) * static_cast<size_t>(nch));
            I.band_y0 = I.band_y1 = 0;
            if (!in->read_tiles(0, 0, info_.x, info_.x + info_.width, info_.y + b0, info_.y + b1, 0,
                                1, I.chbegin, I.chend, OIIO::TypeDesc::FLOAT, I.band.data()))
                throw Error(info_.path + ": read failed at rows " + std::to_string(y0) + "-" +
                            std::to_string(y1 - 1) + ": " + oiio_error(in));
            I.band_y0 = b0;
            I.band_y1 = b1;
        }
        s = I.band.data() + static_cast<size_t>(y0 - I.band_y0) * w * static_cast<size_t>(nch);
    } else {
        scratch_.resize(w * rows * static_cast<size_t>(nch));
        if (!in->read_scanlines(0, 0, info_.y + y0, info_.y + y1, 0, I.chbegin, I.chend,
                                OIIO::TypeDesc::FLOAT, scratch_.data()))
            throw Error(info_.path + ": read failed at rows " + std::to_string(y0) + "-" +
                        std::to_string(y1 - 1) + ": " + oiio_error(in));
        s = scratch_.data();
    }
    // Some readers (JPEG) report a truncated file as an error but still return true.
    if (in->has_error()) throw Error(info_.path + ": read failed: " + oiio_error(in));
    const int* cc = I.color_channels;
    const int a = I.alpha;
    for (size_t i = 0; i < w * rows; ++i, s += nch, rgba += 4) {
        rgba[0] = s[cc[0]];
        rgba[1] = s[cc[1]];
        rgba[2] = s[cc[2]];
        rgba[3] = a >= 0 ? s[a] : 1.0f;
    }
}

namespace {

class OiioPngWriter final : public PngWriter {
  public:
    OiioPngWriter(const std::string& file_path, const std::string& png_path, int width, int height,
                  int channels, const std::vector<std::pair<std::string, std::string>>& attributes)
        : png_path_(png_path) {
        out_ = OIIO::ImageOutput::create("png");
        if (!out_) throw Error(png_path + ": OpenImageIO has no PNG writer: " + OIIO::geterror());
        OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
        spec.attribute("oiio:ColorSpace", "sRGB");
        // Our colour is straight already: without this OIIO's PNG writer would divide it by A
        // again.
        if (channels == 4) spec.attribute("oiio:UnassociatedAlpha", 1);
        for (const auto& [k, v] : attributes) spec.attribute(k, v);
        if (!out_->open(file_path, spec))
            throw Error(png_path + ": cannot write the PNG: " + out_->geterror());
    }
    void write_rows(int y0, int rows, const uint8_t* data) override {
        if (!out_->write_scanlines(y0, y0 + rows, 0, OIIO::TypeDesc::UINT8, data))
            throw Error(png_path_ + ": cannot write the PNG: " + out_->geterror());
    }
    void close() override {
        if (!out_->close()) throw Error(png_path_ + ": cannot write the PNG: " + out_->geterror());
    }

  private:
    std::string png_path_;
    std::unique_ptr<OIIO::ImageOutput> out_;
};

class OiioLibrary final : public ImageLibrary {
  public:
    std::unique_ptr<ImageSource> open_source(const std::string& path,
                                             uint64_t max_pixels) override {
        return OiioImageSource::open(path, max_pixels);
    }
    std::vector<float> integer_code_floats(int bits) override {
        const size_t n = size_t{1} << bits;
        std::vector<float> key(n);
        // Exactly the floats OpenImageIO hands us for these codes (its conversion, not ours).
        if (bits <= 8) {
            std::vector<uint8_t> c8(n);
            for (size_t i = 0; i < n; ++i) c8[i] = static_cast<uint8_t>(i);
            OIIO::convert_pixel_values(OIIO::TypeDesc::UINT8, c8.data(), OIIO::TypeDesc::FLOAT,
                                       key.data(), static_cast<int>(n));
        } else {
            std::vector<uint16_t> c16(n);
            for (size_t i = 0; i < n; ++i) c16[i] = static_cast<uint16_t>(i);
            OIIO::convert_pixel_values(OIIO::TypeDesc::UINT16, c16.data(), OIIO::TypeDesc::FLOAT,
                                       key.data(), static_cast<int>(n));
        }
        return key;
    }
    std::unique_ptr<PngWriter> png_writer(
        const std::string& file_path, const std::string& png_path, int width, int height,
        int channels, const std::vector<std::pair<std::string, std::string>>& attributes) override {
        return std::make_unique<OiioPngWriter>(file_path, png_path, width, height, channels,
                                               attributes);
    }
    void set_threads(int threads) override { OIIO::attribute("threads", threads); }
};

}  // namespace

ImageLibrary* oiio_image_library() {
    static OiioLibrary library;
    return &library;
}

}  // namespace spectex
