#pragma once
// The observer and illuminant tables by the name a command or a file gives (a shipped name or a
// CSV path), read once per process: a verify of a thousand files that record the same observer
// and lights reads each table once, as does a plan that measures 21 candidate grids (and builds a
// method on each), as a bake's set-up does for its batch. A table that cannot be
// read throws the same Error for every caller.
#include <memory>
#include <string>

#include "spectral/measured_prior.h"
#include "spectral/spectrum.h"

namespace spectex {

std::shared_ptr<const Observer> observer_table(const std::string& data_dir,
                                               const std::string& name);
std::shared_ptr<const Spectrum> illuminant_table(const std::string& data_dir,
                                                 const std::string& name_or_file);
// <data_dir>/spectral/vertex_prior_measured.csv, read once per process.
std::shared_ptr<const MeasuredPrior> measured_prior_table(const std::string& data_dir);

}  // namespace spectex
