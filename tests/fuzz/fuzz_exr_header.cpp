// libFuzzer harness: our parsing of spectral-EXR headers, as `spectex info` uses it.
//  1. every line of the input, as a channel name, through parse_reflective_channel;
//  2. the bytes, written to a temporary file, through read_spectral_exr_info (OpenEXR parses the
//     header; we classify channels, read attributes and check the grid). It may only throw
//     spectex::Error.
// Inputs are best started from the seeds in corpus/fuzz_exr_header (small spectral EXRs).
// SPECTEX_FUZZ_OUR_PARSING_ONLY=1 skips step 2 (for OpenEXR 3.1's own reader bugs).
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "base/error.h"
#include "io/spectral_exr_info.h"
#include "spectral/wavelength_grid.h"

static std::string temp_path() {
    static std::string p = [] {
        const char* dir = std::getenv("TMPDIR");
        return std::string(dir && *dir ? dir : "/tmp") + "/spectex-fuzz-exr-" +
               std::to_string(getpid()) + ".exr";
    }();
    return p;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    size_t pos = 0;
    while (pos < text.size()) {
        size_t nl = text.find('\n', pos);
        std::string line = text.substr(pos, nl == std::string::npos ? std::string::npos : nl - pos);
        double l = 0;
        if (spectex::parse_reflective_channel(line, &l) && !std::isfinite(l)) std::abort();
        if (nl == std::string::npos) break;
        pos = nl + 1;
    }
    static const bool ours_only = std::getenv("SPECTEX_FUZZ_OUR_PARSING_ONLY") != nullptr;
    if (ours_only) return 0;
    const std::string path = temp_path();
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return 0;
    std::fwrite(data, 1, size, f);
    std::fclose(f);
    try {
        spectex::SpectralExrInfo info = spectex::read_spectral_exr_info(path);
        for (size_t i = 1; i < info.reflective.size(); ++i)
            if (!(info.reflective[i].lambda > info.reflective[i - 1].lambda)) std::abort();
    } catch (const spectex::Error&) {
    }
    return 0;
}
