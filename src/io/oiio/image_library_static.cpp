// Linked into programs that carry OpenImageIO themselves (unit tests, benchmarks): registers the
// implementation before main, so that nothing is loaded at run time.
#include "io/oiio/oiio_library.h"

namespace {
const bool registered = (spectex::register_image_library(spectex::oiio_image_library()), true);
}  // namespace
