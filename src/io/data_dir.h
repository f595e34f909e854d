#pragma once
#include <string>

namespace spectex {

// The folder holding spectex.ocio and spectral/: $SPECTEX_DATA_DIR, else
// <prefix>/share/spectex/config next to the installed binary, else the source tree's config/ (for a
// build-tree binary).
std::string find_data_dir();

// Where spectex keeps answers worth keeping between runs (the grid search of --wavelengths auto and
// plan): $SPECTEX_CACHE_DIR when it is set (set and empty: no cache), else $XDG_CACHE_HOME/spectex
// when XDG_CACHE_HOME is an absolute path (the XDG base directory convention), else
// $HOME/.cache/spectex when HOME is an existing folder (spectex never makes a home); "" (no
// cache) when none of them is usable.
std::string cache_folder();

// What tells one build of spectex from another: the size and modification time of the running
// executable (a rebuild changes them, so a cache never serves an answer of other code).
std::string executable_identity();

}  // namespace spectex
