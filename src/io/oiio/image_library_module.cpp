// spectex-oiio.so's entry point: the only symbol the module exports.
#include "io/oiio/oiio_library.h"

extern "C" __attribute__((visibility("default"))) spectex::ImageLibrary*
spectex_image_library_v1() {
    return spectex::oiio_image_library();
}
