#include "io/library_stderr.h"

#include <OpenColorIO/OpenColorIO.h>
#include <fcntl.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <ext/stdio_filebuf.h>
#include <future>
#include <iostream>
#include <set>
#include <string>
#include <thread>
#include <utility>

#include "base/text.h"

#if defined(__SANITIZE_ADDRESS__)
#define SPECTEX_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(undefined_behavior_sanitizer)
#define SPECTEX_SANITIZED 1
#endif
#endif
#ifdef SPECTEX_SANITIZED
#include <sanitizer/common_interface_defs.h>
#endif

namespace spectex {

namespace {

bool g_tty = false;
int g_real = -1;                  // the real stderr, once captured
std::future<void> g_reader_done;  // ready when the reader has forwarded everything
LibraryMessages g_mode = LibraryMessages::warnings;

}  // namespace

LibraryLineFilter::LibraryLineFilter(LibraryMessages mode) : mode_(mode) {}

// An error of a library's is already in spectex's own "spectex: <file>: <cause>" line (OpenImageIO
// hands the cause over), so by default only what is not an error is shown: warnings (libpng's
// "iCCP: known incorrect sRGB profile", libtiff's unknown tags, OpenColorIO's deprecations).
bool LibraryLineFilter::shown(const std::string& line) const {
    if (mode_ == LibraryMessages::all) return true;
    if (mode_ == LibraryMessages::none) return false;
    const std::string l = lower_ascii(line);
    if (l.find("[opencolorio info]") != std::string::npos ||
        l.find("[opencolorio debug]") != std::string::npos)
        return false;
    for (size_t p = l.find("error"); p != std::string::npos; p = l.find("error", p + 1)) {
        const bool start = p == 0 || !std::isalpha(static_cast<unsigned char>(l[p - 1]));
        const size_t after =
            p + 5 < l.size() && l[p + 5] == 's' ? p + 6 : p + 5;  // "error", "errors"
        const bool end = after >= l.size() || !std::isalpha(static_cast<unsigned char>(l[after]));
        if (start && end) return false;
    }
    return true;
}

std::string LibraryLineFilter::pass(const std::string& raw) {
    std::string line = raw;
    while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos || !shown(line)) return "";
    if (line.size() > kMaxLine) line = line.substr(0, kMaxLine) + " [...]";
    if (mode_ == LibraryMessages::warnings) {
        if (seen_.count(line)) return "";
        if (seen_.size() < kMaxRemembered) seen_.insert(line);
    }
    return "spectex: library: " + one_line(line) + "\n";
}

bool stderr_is_terminal() { return g_tty; }

int real_stderr_descriptor() { return g_real >= 0 ? g_real : 2; }

void capture_library_stderr() {
    static bool done = false;
    if (done) return;
    g_tty = ::isatty(2) == 1;
    int real = ::dup(2);
    int p[2];
    if (real < 0 || ::pipe(p) != 0) return;  // keep things as they are rather than lose messages
    ::fcntl(real, F_SETFD, FD_CLOEXEC);
    ::fcntl(p[0], F_SETFD, FD_CLOEXEC);
    std::cerr.flush();
    ::dup2(p[1], 2);
    ::close(p[1]);
    g_real = real;
    if (const char* e = std::getenv("SPECTEX_LIBRARY_MESSAGES")) {
        if (std::strcmp(e, "0") == 0)
            g_mode = LibraryMessages::none;
        else if (std::strcmp(e, "1") == 0 || std::strcmp(e, "all") == 0)
            g_mode = LibraryMessages::all;
    }
    // OpenColorIO logs through std::cerr (now the real stderr), not through descriptor 2: send its
    // messages the same way as the other libraries'.
    OCIO_NAMESPACE::SetLoggingFunction([](const char* message) {
        std::string m = message ? message : "";
        if (!m.empty() && m.back() != '\n') m += '\n';
        (void)!::write(2, m.data(), m.size());
    });
    // OCIO reads $OCIO_LOGGING_LEVEL on first use and complains about a bad one on std::cerr:
    // make that first use now, while std::cerr still reaches descriptor 2 (the pipe).
    (void)OCIO_NAMESPACE::GetLoggingLevel();
#ifdef SPECTEX_SANITIZED
    // A sanitizer's report must reach the real stderr, not the pipe of library messages (no
    // longer read at exit, where leak reports are written).
    __sanitizer_set_report_fd(reinterpret_cast<void*>(static_cast<intptr_t>(real)));
#endif
    // Never destroyed: std::cerr keeps pointing at it until the very end (the standard streams are
    // flushed after every static destructor has run), and its descriptor must stay open for the
    // sanitizer's report at exit. A static object here was destroyed first and closed `real`, so
    // a leak check's report went to a closed descriptor and the sanitizer died silently with its
    // exit code (the report hidden so was the false leak described below).
    static auto* ours = new __gnu_cxx::stdio_filebuf<char>(real, std::ios::out);
    std::cerr.rdbuf(ours);
    // The reader signals once it runs: a command as short as `spectex --help` could otherwise exit
    // while the thread is still being set up, and LeakSanitizer's exit check then reports the
    // thread attributes that glibc and the sanitizer runtime hold during a thread's start (a false
    // "leak" of 184 bytes, in about 1 of 60 runs under ASan).
    std::promise<void> started, finished;
    std::future<void> running = started.get_future();
    g_reader_done = finished.get_future();
    std::thread([fd = p[0], started = std::move(started),
                 finished = std::move(finished)]() mutable {
        started.set_value();
        LibraryLineFilter filter(g_mode);
        auto forward = [&filter](const std::string& raw) {
            const std::string out = filter.pass(raw);
            if (!out.empty()) (void)!::write(g_real, out.data(), out.size());
        };
        std::string line;
        char buf[4096];
        for (;;) {
            const ssize_t n = ::read(fd, buf, sizeof buf);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) break;
            for (ssize_t i = 0; i < n; ++i) {
                line += buf[i];
                if (buf[i] == '\n') {
                    forward(line);
                    line.clear();
                }
            }
        }
        if (!line.empty()) forward(line);
        finished.set_value();
    }).detach();
    running.wait();
    done = true;
}

void finish_library_stderr() {
    if (g_real < 0 || !g_reader_done.valid()) return;
    std::cerr.flush();
    // Descriptor 2 back to the real stderr closes the pipe's last writer: the reader forwards what
    // is left and stops. Waited for (briefly), so a library's last warning is not lost at exit.
    ::dup2(g_real, 2);
    g_reader_done.wait_for(std::chrono::seconds(2));
}

}  // namespace spectex
