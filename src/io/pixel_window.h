#pragma once

namespace spectex {

// An image's data window (the pixels stored: origin and size) and display window (the frame they
// sit in), as OpenEXR and OpenImageIO define them. A source's windows are its output's, so both
// structs that carry them derive from this one and hand them over in one assignment.
struct PixelWindows {
    int x = 0, y = 0, width = 0, height = 0;                      // data window origin and size
    int full_x = 0, full_y = 0, full_width = 0, full_height = 0;  // display window
};

}  // namespace spectex
