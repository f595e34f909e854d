#pragma once
#include <string>

namespace spectex {

// The folder holding spectex.ocio and spectral/: $SPECTEX_DATA_DIR, else
// <prefix>/share/spectex/config next to the installed binary, else the source tree's config/ (for a
// build-tree binary).
std::string find_data_dir();

}  // namespace spectex
