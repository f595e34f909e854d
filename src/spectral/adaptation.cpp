#include "spectral/adaptation.h"

#include <cmath>

namespace spectex {

Eigen::Matrix3d bradford_matrix() {
    Eigen::Matrix3d m;
    m << 0.8951, 0.2664, -0.1614,  //
        -0.7502, 1.7135, 0.0367,   //
        0.0389, -0.0685, 1.0296;
    return m;
}

Eigen::Matrix3d bradford_adaptation(const Eigen::Vector3d& src_white,
                                    const Eigen::Vector3d& dst_white) {
    if (src_white == dst_white) return Eigen::Matrix3d::Identity();
    const Eigen::Matrix3d m = bradford_matrix();
    const Eigen::Vector3d s = m * src_white, d = m * dst_white;
    return m.inverse() * d.cwiseQuotient(s).asDiagonal() * m;
}

double srgb_encode_clipped(double l) {
    if (!(l > 0)) return 0.0;
    if (l >= 1) return 1.0;
    return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055;
}

int srgb8(double linear) {
    return static_cast<int>(std::lround(srgb_encode_clipped(linear) * 255.0));
}

}  // namespace spectex
