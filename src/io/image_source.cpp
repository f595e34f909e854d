#include "io/image_source.h"

#include <OpenImageIO/imageio.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <cerrno>
#include <cstring>

#include "spectral/error.h"

namespace spectex {

struct ImageSource::Impl {
    std::unique_ptr<OIIO::ImageInput> in;
    int color_channels[3] = {0, 0, 0};
    bool tiled = false;
    std::vector<float> whole;  // tiled inputs: the whole first level, read once
};

ImageSource::~ImageSource() {
    if (impl_ && impl_->in) impl_->in->close();
}

namespace {

std::string oiio_error(OIIO::ImageInput* in) {
    std::string e = in ? in->geterror() : OIIO::geterror();
    while (!e.empty() && (e.back() == '\n' || e.back() == ' ')) e.pop_back();
    return e.empty() ? "unknown OpenImageIO error" : e;
}

}  // namespace

std::unique_ptr<ImageSource> ImageSource::open(const std::string& path, uint64_t max_pixels) {
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) throw Error(path + ": " + std::strerror(errno));
    if (S_ISDIR(st.st_mode)) throw Error(path + ": is a directory");
    if (!S_ISREG(st.st_mode)) throw Error(path + ": not a regular file");
    if (st.st_size == 0) throw Error(path + ": empty file");
    // OIIO says only "Could not open file": ask the system for the cause first.
    if (int fd = ::open(path.c_str(), O_RDONLY); fd < 0)
        throw Error(path + ": " + std::strerror(errno));
    else
        ::close(fd);

    // Unassociated alpha as stored: OIIO would otherwise premultiply PNG alpha on gamma-encoded
    // 8-bit values, before we linearise.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) throw Error(path + ": cannot read: " + oiio_error(nullptr));

    std::unique_ptr<ImageSource> src(new ImageSource);
    src->impl_ = std::make_unique<Impl>();
    const OIIO::ImageSpec& spec = in->spec();
    SourceInfo& info = src->info_;
    info.path = path;
    info.format_name = in->format_name();
    info.x = spec.x;
    info.y = spec.y;
    info.width = spec.width;
    info.height = spec.height;
    info.full_x = spec.full_x;
    info.full_y = spec.full_y;
    info.full_width = spec.full_width;
    info.full_height = spec.full_height;
    info.channels = spec.nchannels;
    if (spec.width <= 0 || spec.height <= 0) throw Error(path + ": image has no pixels");
    if (spec.depth > 1) throw Error(path + ": volume images (depth " + std::to_string(spec.depth) + ") are not supported");
    if (spec.deep) throw Error(path + ": deep images are not supported");
    uint64_t pixels = static_cast<uint64_t>(spec.width) * static_cast<uint64_t>(spec.height);
    if (pixels > max_pixels)
        throw Error(path + ": " + std::to_string(spec.width) + "x" + std::to_string(spec.height) +
                    " pixels exceed the limit of " + std::to_string(max_pixels) + " (--max-pixels)");
    if (spec.nchannels < 1) throw Error(path + ": image has no channels");

    info.is_float = spec.format.basetype == OIIO::TypeDesc::FLOAT ||
                    spec.format.basetype == OIIO::TypeDesc::HALF ||
                    spec.format.basetype == OIIO::TypeDesc::DOUBLE;
    info.bits = static_cast<int>(spec.format.size() * 8);
    if (int b = spec.get_int_attribute("oiio:BitsPerSample", 0); b > 0 && !info.is_float) info.bits = b;
    info.colorspace_hint = spec.get_string_attribute("oiio:ColorSpace");
    info.miplevels = 1;
    while (in->seek_subimage(0, info.miplevels)) ++info.miplevels;
    info.subimages = 1;
    while (in->seek_subimage(info.subimages, 0)) ++info.subimages;
    if (!in->seek_subimage(0, 0)) throw Error(path + ": " + oiio_error(in.get()));
    (void)in->geterror();  // counting levels probed one past the last: forget that error

    // Channels: grey, grey+alpha, RGB, RGBA; extra channels are ignored.
    int alpha = spec.alpha_channel;
    if (alpha < 0 && spec.nchannels == 2) alpha = 1;
    if (alpha < 0 && spec.nchannels >= 4) alpha = 3;
    std::vector<int> colour;
    for (int c = 0; c < spec.nchannels && colour.size() < 3; ++c)
        if (c != alpha) colour.push_back(c);
    if (colour.size() == 1 || colour.size() == 2) colour.resize(1);
    if (colour.size() == 1) colour = {colour[0], colour[0], colour[0]};
    for (int i = 0; i < 3; ++i) src->impl_->color_channels[i] = colour[static_cast<size_t>(i)];
    info.alpha_channel = alpha;
    if (alpha >= 0)
        info.alpha = spec.get_int_attribute("oiio:UnassociatedAlpha", 0) ? AlphaKind::Unassociated
                                                                         : AlphaKind::Associated;
    src->impl_->tiled = spec.tile_width > 0;
    src->impl_->in = std::move(in);
    return src;
}

void ImageSource::read_rgba(int y0, int y1, float* rgba) {
    const int nch = info_.channels;
    const size_t w = static_cast<size_t>(info_.width);
    const size_t rows = static_cast<size_t>(y1 - y0);
    OIIO::ImageInput* in = impl_->in.get();
    const float* s;
    if (impl_->tiled) {
        // OIIO 2.4's read_scanlines divides by zero on tiled TIFFs when it converts types, and
        // bands of rows need not be tile-aligned: read the whole level once (the RGB input is the
        // one thing DESIGN.md allows to be whole in memory).
        if (impl_->whole.empty()) {
            impl_->whole.resize(w * static_cast<size_t>(info_.height) * static_cast<size_t>(nch));
            if (!in->read_image(0, 0, 0, nch, OIIO::TypeDesc::FLOAT, impl_->whole.data()))
                throw Error(info_.path + ": read failed: " + oiio_error(in));
        }
        s = impl_->whole.data() + static_cast<size_t>(y0) * w * static_cast<size_t>(nch);
    } else {
        scratch_.resize(w * rows * static_cast<size_t>(nch));
        if (!in->read_scanlines(0, 0, info_.y + y0, info_.y + y1, 0, 0, nch, OIIO::TypeDesc::FLOAT,
                                scratch_.data()))
            throw Error(info_.path + ": read failed at rows " + std::to_string(y0) + "-" +
                        std::to_string(y1 - 1) + ": " + oiio_error(in));
        s = scratch_.data();
    }
    // Some readers (JPEG) report a truncated file as an error but still return true.
    if (in->has_error()) throw Error(info_.path + ": read failed: " + oiio_error(in));
    const int* cc = impl_->color_channels;
    const int a = info_.alpha_channel;
    for (size_t i = 0; i < w * rows; ++i, s += nch, rgba += 4) {
        rgba[0] = s[cc[0]];
        rgba[1] = s[cc[1]];
        rgba[2] = s[cc[2]];
        rgba[3] = a >= 0 ? s[a] : 1.0f;
    }
}

}  // namespace spectex
