#pragma once
// The OpenImageIO side of spectex (decoding textures, writing PNGs), in a module loaded on first
// use. OpenImageIO links about 260 shared libraries (codecs, OpenCV, FFmpeg, ...): loading them
// took ~75 ms, 12k page faults and 130 MB of resident memory at every start, `spectex --version`
// and a no-op `bake --update` included. Commands that never decode an image (info, an --update run
// whose files are all up to date, basis, plan, verify without --source) no longer pay for it.
//
// The spectex executable loads spectex-oiio.so from its own folder (the build tree), else from
// <bindir>/../<libdir>/spectex (installed); SPECTEX_MODULE_DIR overrides both. Programs that link
// the OpenImageIO objects themselves (tests, benchmarks) register them instead
// (image_library_static.cpp).
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace spectex {

class ImageSource;

// An 8-bit PNG being written (render): rows in order, then close().
class PngWriter {
  public:
    virtual ~PngWriter() = default;
    virtual void write_rows(int y0, int rows, const uint8_t* data) = 0;  // throws Error
    virtual void close() = 0;                                            // throws Error
};

class ImageLibrary {
  public:
    virtual ~ImageLibrary() = default;
    // ImageSource::open's work (io/image_source.h).
    virtual std::unique_ptr<ImageSource> open_source(const std::string& path,
                                                     uint64_t max_pixels) = 0;
    // The floats the reader gives for integer codes 0 .. 2^bits - 1 (8 or 16-bit storage).
    virtual std::vector<float> integer_code_floats(int bits) = 0;
    // Writes to `file_path` (a temporary file); `png_path` names the output in messages.
    virtual std::unique_ptr<PngWriter> png_writer(
        const std::string& file_path, const std::string& png_path, int width, int height,
        int channels, const std::vector<std::pair<std::string, std::string>>& attributes) = 0;
    virtual void set_threads(int threads) = 0;
};

// The library, loaded on the first call. Throws Error when the module cannot be loaded.
ImageLibrary& image_library();
// OpenImageIO's thread count: applied now when the library is loaded, else when it loads.
void set_image_threads(int threads);
// For programs that link the implementation (image_library_static.cpp).
void register_image_library(ImageLibrary* library);

}  // namespace spectex

// The module's one entry point (C linkage, so dlsym finds it by this name).
#define SPECTEX_IMAGE_LIBRARY_ENTRY "spectex_image_library_v1"
