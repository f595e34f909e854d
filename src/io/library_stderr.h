#pragma once
#include <cstddef>
#include <set>
#include <string>

namespace spectex {

// Image libraries (libpng through OpenImageIO, for one) print their own messages straight to file
// descriptor 2, and OpenColorIO logs through std::cerr. This keeps stderr ours: std::cerr writes
// to the real stderr, and whatever else reaches descriptor 2 goes through a pipe to a thread that
// forwards it one line at a time, prefixed "spectex: library: " and made printable (one_line).
// What it forwards is set by $SPECTEX_LIBRARY_MESSAGES:
//   unset   warnings: each distinct line once per run; lines that name an error are left out
//           (spectex's own "spectex: <file>: <cause>" line carries the cause), and so are
//           OpenColorIO's info and debug messages;
//   0       nothing;
//   1, all  every line, as it comes.
enum class LibraryMessages { warnings, none, all };

// The rule above, one line at a time: pass() returns the line to print ("spectex: library: ...\n",
// at most kMaxLine bytes of the library's text) or "" when the line is not shown.
class LibraryLineFilter {
  public:
    static constexpr size_t kMaxLine = 1000;
    static constexpr size_t kMaxRemembered = 10000;  // distinct lines remembered for "once per run"
    explicit LibraryLineFilter(LibraryMessages mode);
    std::string pass(const std::string& raw_line);

  private:
    bool shown(const std::string& line) const;
    LibraryMessages mode_;
    std::set<std::string> seen_;
};

void capture_library_stderr();
// Forwards what the libraries printed last and gives descriptor 2 back to the real stderr; call
// once, at the end of main.
void finish_library_stderr();
// The descriptor of the real stderr: 2 until captured, then the copy that std::cerr writes to.
// Output that a user sends to standard error (--json /dev/stderr) is written there.
int real_stderr_descriptor();
// Whether the real stderr is a terminal (descriptor 2 itself is a pipe once captured).
bool stderr_is_terminal();

}  // namespace spectex
