#pragma once
// verify's measuring kernel (pipeline/verify_measure.cpp), apart from the set-up from what the file
// records (pipeline/verify.cpp): what the set-up hands the kernel, and the call that measures a
// file.
#include <Eigen/Dense>
#include <cstddef>
#include <vector>

#include "pipeline/verify.h"

namespace spectex {

class ImageSource;
class Linearizer;
class SpectralReader;

// Another light: XYZ weights already adapted to the check light's white (Bradford), so that the
// adapted XYZ of a spectrum S is xyz_weights · S.
struct OtherLight {
    Eigen::Matrix3Xd xyz_weights;
};

// What the set-up (verify_file) gives the kernel: the band's shape, the check light's weights and
// matrices, what is compared, and the other lights.
struct MeasureContext {
    size_t w = 0, plane = 0;  // plane = w * band_rows
    int bins = 0;
    int x0 = 0, y0 = 0;            // data window origin, for reported coordinates
    const double* wrgb = nullptr;  // 3 x bins, column-major (Eigen)
    Eigen::Matrix3d rgb_to_xyz, xyz_to_rgb;
    Eigen::Vector3d white;
    bool has_alpha = false, associated = false, compare = false;
    // Associated files: the range check is on the straight samples T/A, each bin allowed its
    // relative rounding step above 1 (straight_tol, bins values; see verify_file).
    std::vector<float> straight_tol;
    const Linearizer* encoder =
        nullptr;  // re-encodes linear Rec.709 to the source's space (code check)
    double max_code = 255;
    bool source_associated = false;
    std::vector<OtherLight> lights;
};

// Reads the file (and the source, when ctx.compare) a band of band_rows rows at a time, the next
// band while this one is measured, and fills r's figures: samples outside [0, 1], the linear RGB
// range, the comparison with the source and the other lights. The source's pixels go through the
// bake's policies as r records them (r.out_of_range), its clamped and replaced pixels counted.
void measure_file(SpectralReader& reader, ImageSource* src, const Linearizer& lin,
                  const MeasureContext& ctx, int band_rows, const VerifySettings& s,
                  VerifyReport& r);

}  // namespace spectex
