#pragma once
// The lattice's `measured` vertex prior: a Gaussian model of measured reflectances in the tanh
// space of LHTSS (s = (tanh z + 1) / 2), learned by config/spectral/make_vertex_prior.py and
// shipped as config/spectral/vertex_prior_measured.csv: a wavelength column, the mean z, optionally
// the mean z on the RGB cube's faces, and m scaled principal directions f1..fm (the covariance is
// G + F F', see spectral/lhtss.h).
#include <string>
#include <vector>

#include "spectral/lhtss.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

struct MeasuredPrior {
    std::vector<double> lambda;  // nm, strictly increasing
    std::vector<double> mean;    // z, at the vertices inside the RGB cube
    // z at the vertices on the cube's faces (a channel 0 or 1, where every colour clipped to the
    // gamut lands); empty: `mean` there too. The colours clipped to sRGB are not their measured
    // colour, and a mean learned from measured reflectances pulls them further from it.
    std::vector<double> face_mean;
    std::vector<std::vector<double>> factors;  // factors[j][k]: direction j at lambda[k]
    // "fnv1a64:<16 hex>" over the values read: the lattice's recipe carries it, so a changed
    // table is a changed method (--update rebakes, caches miss).
    std::string checksum;
};

// Reads and checks the table (header "wavelength,mean[,face_mean],f1,...,fm", finite values,
// |mean| and |face_mean| <= 20):
// throws Error naming the file and the cause.
MeasuredPrior read_measured_prior_csv(const std::string& path);
// <data_dir>/spectral/vertex_prior_measured.csv.
std::string measured_prior_path(const std::string& data_dir);

// The model on a bake's grid: mean (the face mean with `face`) and directions interpolated
// linearly in λ, held constant past the table's ends (the covariance is a function of λ; its
// roughness part is grid-independent).
TanhPrior measured_prior_on_grid(const MeasuredPrior& p, const WavelengthGrid& grid,
                                 bool face = false);

}  // namespace spectex
