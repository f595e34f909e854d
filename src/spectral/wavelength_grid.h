#pragma once
// Wavelength grids: the bins of the output file, and the weights used to integrate over them.
#include <string>
#include <vector>

namespace spectex {

// The most bins any grid may have, wherever it comes from (--wavelengths, --grids, a wavelength
// file, a basis CSV, a spectral EXR's channels): 4,701, 0.1 nm over 360-830 nm, the finest grid a
// renderer samples. A bake of 512x256 pixels on 40,001 bins took 72 s, 4.0 GB, 320 MB; on 4,001,
// 54 s (2 busy cores), 0.58 GB, 240 MB: memory is about 0.2 GB + 190 bytes x bins x image width.
// A grid over the limit throws LimitError naming the bins and the limit.
constexpr size_t kMaxGridBins = 4701;

struct WavelengthGrid {
    std::vector<double> lambda;  // nm, strictly increasing
    std::vector<double> weight;  // integration weight of each bin, nm
    bool uniform = true;
    double step = 0.0;  // for uniform grids

    size_t size() const { return lambda.size(); }
    // "380:780:5" for uniform grids, else "list of N wavelengths"
    std::string describe() const;

    // START:END:STEP; lambda_k = START + k*STEP; END included when on the grid within 1e-6 nm.
    static WavelengthGrid parse(const std::string& spec);
    // parse(), and END must be a bin: what users type (400:700:7 is an error naming 400:694:7).
    static WavelengthGrid parse_exact(const std::string& spec);
    static WavelengthGrid uniform_grid(double start, double end, double step);
    // Arbitrary strictly increasing list: trapezoid weights (a uniform list gets uniform weights).
    static WavelengthGrid from_list(std::vector<double> lambdas);
    // One wavelength per line; '#' comments and blank lines ignored.
    static WavelengthGrid from_file(const std::string& path);
};

// Shortest decimal that holds lambda to 1e-6 nm, '.' as separator: "380", "383.7".
std::string format_wavelength(double lambda_nm);
// Fichet 2021 reflective channel name: "T.380nm", "T.383,7nm".
std::string reflective_channel_name(double lambda_nm);
// Parses "T.<λ>nm" (comma or dot decimal separator); false if the name is not a reflective channel.
bool parse_reflective_channel(const std::string& name, double* lambda_nm);

// Same wavelengths within tol nm.
bool same_wavelengths(const std::vector<double>& a, const std::vector<double>& b,
                      double tol = 1e-6);

}  // namespace spectex
