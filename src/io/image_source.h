#pragma once
// Reading textures with OpenImageIO, a band of scanlines at a time, as float RGBA.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "io/alpha_kind.h"
#include "io/pixel_window.h"
#include "io/source_identity.h"

namespace spectex {

// What a file says of its colour, as its reader found it (io/linearizer chooses from it).
struct ColourTags {
    std::string format;  // OIIO's format name
    std::string hint;    // OpenImageIO's oiio:ColorSpace ("sRGB", "linear", "Gamma2.2", ...)
    // What in the file states the hint ("sRGB chunk", "gAMA chunk", "Exif ColorSpace", "DPX
    // transfer", ...); "" when OpenImageIO assumed it for the format: an untagged PNG, JPEG, GIF or
    // WebP is sRGB to it, an OpenEXR or Radiance HDR file linear, a PNM file Rec709, whatever
    // the file holds.
    std::string hint_from;
    std::vector<unsigned char> icc;  // the embedded ICC profile's bytes (io/icc_profile.h)
    bool icc_refused = false;        // PNG: an iCCP chunk that libpng refused as malformed
    // The profile as read back from a header (colour_tags_from_record): its description, or why
    // none could be read; the bytes are not recorded.
    std::string icc_description, icc_problem;
    std::vector<float> chromaticities;  // OpenEXR's chromaticities: R, G, B, white x,y (8 values)
};

struct SourceInfo : PixelWindows {
    std::string path;
    std::string format_name;  // OIIO's format name: "png", "openexr", ...
    int channels = 0;         // in the file
    int alpha_channel = -1;   // index in the file, -1 when none (only a channel named A/alpha
                              // in OpenEXR; never depth or other data)
    AlphaKind alpha = AlphaKind::None;
    bool is_float = false;  // float or half samples
    int bits = 8;           // bits per sample in the file (8, 16, 32, ...)
    ColourTags colour;      // what the file says of its colour
    int subimages = 1;
    int miplevels = 1;
    std::vector<std::string>
        notes;  // how channels were chosen, when not plainly (a layer's R, G, B)
};

// A texture being read: OpenImageIO's reader, in the image module (io/image_library.h).
class ImageSource {
  public:
    // Opens `path` (a regular file, checked before any library opens it) and checks its header;
    // refuses images above max_pixels before allocating. Colour and alpha channels are chosen by
    // name in OpenEXR (R,G,B; Y; a layer's; alpha only from A/alpha), by position in formats
    // without channel names; a file without colour channels is refused. Loads the image module.
    static std::unique_ptr<ImageSource> open(const std::string& path, uint64_t max_pixels);
    virtual ~ImageSource() = default;

    const SourceInfo& info() const { return info_; }
    // Size and modification time of the file opened (fstat of the descriptor the reader uses).
    const SourceIdentity& identity() const { return identity_; }
    // FNV-1a 64 of the file's bytes, "fnv1a64:<hex>", for spectex:sourceHash: computed on the bytes
    // the decoder read, in file order; call after the last read_rgba. Bytes the decoder skipped or
    // read out of order (and the whole file, for the few readers that cannot read through our
    // descriptor) are read now, from the page cache in practice.
    virtual std::string content_hash() = 0;
    // Reads rows [y0, y1) of the data window (0-based, relative to info().y) as packed RGBA float;
    // grey is replicated to RGB and alpha is 1 when the file has none. Values are as stored
    // (associated or not: see info().alpha).
    virtual void read_rgba(int y0, int y1, float* rgba) = 0;

  protected:
    ImageSource() = default;
    SourceInfo info_;
    SourceIdentity identity_;
};

}  // namespace spectex
