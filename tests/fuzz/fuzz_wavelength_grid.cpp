// libFuzzer harness: the wavelength-grid parser (--wavelengths START:END:STEP), the list of
// wavelengths behind --wavelengths-file (from_list) and Fichet channel names "T.<λ>nm".
// Any input may be rejected with spectex::Error; nothing else may escape, crash or hang, and an
// accepted grid must satisfy what the output file relies on: finite, strictly increasing
// wavelengths whose channel names parse back to them and are distinct.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "base/error.h"
#include "spectral/wavelength_grid.h"

static void check_grid(const spectex::WavelengthGrid& g) {
    if (g.lambda.size() != g.weight.size()) std::abort();
    for (size_t i = 0; i < g.lambda.size(); ++i) {
        if (!std::isfinite(g.lambda[i]) || !std::isfinite(g.weight[i])) std::abort();
        if (i > 0 && !(g.lambda[i] > g.lambda[i - 1])) std::abort();  // strictly increasing
    }
    (void)g.describe();
    // Channel names of the first 64 bins and of the last one.
    std::vector<size_t> idx;
    for (size_t i = 0; i < g.lambda.size() && i < 64; ++i) idx.push_back(i);
    if (g.lambda.size() > 64) idx.push_back(g.lambda.size() - 1);
    double prev = -HUGE_VAL;
    for (size_t i : idx) {
        double back = 0;
        const std::string name = spectex::reflective_channel_name(g.lambda[i]);
        if (!spectex::parse_reflective_channel(name, &back)) std::abort();  // name not readable
        if (std::fabs(back - g.lambda[i]) > 1e-5 * std::max(1.0, std::fabs(g.lambda[i])))
            std::abort();
        if (!(back > prev)) std::abort();  // two bins, one name
        prev = back;
    }
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    try {
        check_grid(spectex::WavelengthGrid::parse(text));
    } catch (const spectex::Error&) {
    }
    double l = 0;
    if (spectex::parse_reflective_channel(text, &l) && !std::isfinite(l)) std::abort();
    // The text as a list of wavelengths, one per line.
    try {
        std::vector<double> v;
        size_t pos = 0;
        while (pos <= text.size() && v.size() < 4096) {
            size_t nl = text.find('\n', pos);
            std::string line =
                text.substr(pos, nl == std::string::npos ? std::string::npos : nl - pos);
            char* end = nullptr;
            double x = std::strtod(line.c_str(), &end);
            if (end != line.c_str()) v.push_back(x);
            if (nl == std::string::npos) break;
            pos = nl + 1;
        }
        check_grid(spectex::WavelengthGrid::from_list(v));
    } catch (const spectex::Error&) {
    }
    return 0;
}
