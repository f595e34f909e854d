#pragma once
// The OpenColorIO config a command uses: which file (--config, $OCIO, the shipped one), read as a
// regular file of bounded size, parsed once per process for the same path and bytes, its LUT
// files checked before OpenColorIO reads them, and its checksum. Choosing and applying a colour
// space from it is io/linearizer's.
#include <OpenColorIO/OpenColorABI.h>  // OCIO_NAMESPACE only: callers need not parse OpenColorIO

#include <memory>
#include <string>
#include <vector>

namespace OCIO_NAMESPACE {
class Config;
}

namespace spectex {

// The OCIO config a command uses: --config, else $OCIO, else <data_dir>/spectex.ocio.
std::string ocio_config_path(const std::string& data_dir, const std::string& config_override);

// The config at `path`, read from checked bytes (never a device or a FIFO) with the working folder
// OpenColorIO's CreateFromFile would give it, every LUT file it references checked as a regular
// file of bounded size. Parsed once per process for the same path and bytes (at most 8 kept); the
// file is read every time, so a config edited during a batch is parsed anew. Throws Error naming
// the file.
std::shared_ptr<const OCIO_NAMESPACE::Config> load_ocio_config(const std::string& path);

// The files that config reads: itself and the LUT files its transforms reference, resolved through
// its context. Throws Error when the config cannot be read (not a regular file, too large, ...).
std::vector<std::string> ocio_config_files(const std::string& config_path);

// "fnv1a64:<hex>" of an OCIO config's bytes (recorded as spectex:configChecksum, so that verify
// knows whether the config a file was baked with is still the same). Throws Error as every reader.
std::string config_checksum(const std::string& config_path);

}  // namespace spectex
