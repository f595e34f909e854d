#pragma once

namespace spectex {

// Image libraries (libpng through OpenImageIO, for one) print their own complaints straight to
// file descriptor 2, before our "spectex: <file>: <cause>" line, which already carries the cause
// OIIO reports. This keeps stderr ours: std::cerr writes to the real stderr, and whatever else
// reaches descriptor 2 goes through a pipe to a thread that drops it, or forwards it prefixed
// "spectex: library: " when SPECTEX_LIBRARY_MESSAGES=1.
void capture_library_stderr();
// Whether the real stderr is a terminal (descriptor 2 itself is a pipe once captured).
bool stderr_is_terminal();

}  // namespace spectex
