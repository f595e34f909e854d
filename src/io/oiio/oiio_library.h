#pragma once
// The OpenImageIO implementation of ImageLibrary (io/image_library.h), for the module's entry
// point and for programs that link it directly.
#include "io/image_library.h"

namespace spectex {
ImageLibrary* oiio_image_library();
}  // namespace spectex
