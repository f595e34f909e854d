#include "io/library_stderr.h"

#include <OpenColorIO/OpenColorIO.h>
#include <ext/stdio_filebuf.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <future>
#include <string>
#include <thread>
#include <utility>

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
}

bool stderr_is_terminal() { return g_tty; }

void capture_library_stderr() {
    static bool done = false;
    if (done) return;
    g_tty = ::isatty(2) == 1;
    int real = ::dup(2);
    int p[2];
    if (real < 0 || ::pipe(p) != 0) return;  // keep things as they are rather than lose messages
    std::cerr.flush();
    ::dup2(p[1], 2);
    ::close(p[1]);
    const bool forward = [] {
        const char* e = std::getenv("SPECTEX_LIBRARY_MESSAGES");
        return e && std::strcmp(e, "1") == 0;
    }();
    // OpenColorIO logs through std::cerr (now the real stderr), not through descriptor 2: send its
    // warnings the same way as the other libraries' messages.
    OCIO_NAMESPACE::SetLoggingFunction([](const char* message) {
        std::string m = message ? message : "";
        if (!m.empty() && m.back() != '\n') m += '\n';
        (void)!::write(2, m.data(), m.size());
    });
    // OCIO reads $OCIO_LOGGING_LEVEL on first use and complains about a bad one on std::cerr:
    // make that first use now, while std::cerr still reaches descriptor 2 (the pipe).
    (void)OCIO_NAMESPACE::GetLoggingLevel();
#ifdef SPECTEX_SANITIZED
    // A sanitizer's report must reach the real stderr, not the pipe of library chatter (which is
    // dropped, and no longer read at exit, where leak reports are written).
    __sanitizer_set_report_fd(reinterpret_cast<void*>(static_cast<intptr_t>(real)));
#endif
    // Never destroyed: std::cerr keeps pointing at it until the very end (the standard streams are
    // flushed after every static destructor has run), and its descriptor must stay open for the
    // sanitizer's report at exit. A static object here was destroyed first and closed `real`, so
    // the leak check's report went to a closed descriptor and the sanitizer died silently with
    // its exit code (1 in 1 of ~150 runs of a command as short as `spectex bakee`).
    static auto* ours = new __gnu_cxx::stdio_filebuf<char>(real, std::ios::out);
    std::cerr.rdbuf(ours);
    // The reader signals once it runs: a command as short as `spectex --help` could otherwise exit
    // while the thread is still being set up, and LeakSanitizer's exit check then reports the
    // thread attributes that glibc and the sanitizer runtime hold during a thread's start (a false
    // "leak" of 184 bytes, in about 1 of 60 runs under ASan).
    std::promise<void> started;
    std::future<void> running = started.get_future();
    std::thread([fd = p[0], real, forward, started = std::move(started)]() mutable {
        started.set_value();
        std::string line;
        char buf[4096];
        for (;;) {
            ssize_t n = ::read(fd, buf, sizeof buf);
            if (n <= 0) return;
            if (!forward) continue;
            for (ssize_t i = 0; i < n; ++i) {
                line += buf[i];
                if (buf[i] == '\n') {
                    std::string out = "spectex: library: " + line;
                    (void)!::write(real, out.data(), out.size());
                    line.clear();
                }
            }
        }
    }).detach();
    running.wait();
    done = true;
}

}  // namespace spectex
