#include "io/atomic_file.h"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <vector>

#include "base/bounded_read.h"
#include "base/error.h"
#include "io/library_stderr.h"
#include "io/paths.h"

namespace spectex {

namespace {

// Live temporary files, readable from a signal handler (fixed storage, no allocation).
constexpr int kSlots = 64;
char g_paths[kSlots][PATH_MAX];
std::atomic<bool> g_used[kSlots];
std::mutex g_slot_mutex;

int take_slot(const std::string& path) {
    if (path.size() >= PATH_MAX) return -1;
    std::lock_guard<std::mutex> lock(g_slot_mutex);
    for (int i = 0; i < kSlots; ++i) {
        if (!g_used[i].load()) {
            std::memcpy(g_paths[i], path.c_str(), path.size() + 1);
            g_used[i].store(true);
            return i;
        }
    }
    return -1;
}

void release_slot(int slot) {
    if (slot >= 0) g_used[slot].store(false);
}

extern "C" void cleanup_and_reraise(int sig) {
    for (int i = 0; i < kSlots; ++i)
        if (g_used[i].load()) ::unlink(g_paths[i]);
    ::signal(sig, SIG_DFL);
    ::raise(sig);
}

// defer_termination_requests: the first SIGTERM, SIGINT or SIGHUP is recorded, not acted on
// (lock-free atomics only: safe in a handler).
std::atomic<bool> g_defer{false};
std::atomic<int> g_requested{0};

extern "C" void on_terminating_signal(int sig) {
    if ((sig == SIGTERM || sig == SIGINT || sig == SIGHUP) && g_defer.load()) {
        int none = 0;
        if (g_requested.compare_exchange_strong(none, sig)) return;
    }
    cleanup_and_reraise(sig);
}

mode_t current_umask() {
    static const mode_t mask = [] {
        mode_t m = ::umask(022);
        ::umask(m);
        return m;
    }();
    return mask;
}

}  // namespace

// Every signal whose default action ends the process (POSIX "T" and "A"), real-time ones too.
std::vector<int> terminating_signals() {
    std::vector<int> v = {SIGHUP,  SIGINT,    SIGQUIT, SIGILL,  SIGTRAP, SIGABRT, SIGBUS,
                          SIGFPE,  SIGUSR1,   SIGSEGV, SIGUSR2, SIGPIPE, SIGALRM, SIGTERM,
                          SIGXCPU, SIGVTALRM, SIGPROF, SIGSYS,  SIGIO,   SIGPWR,  SIGSTKFLT};
    for (int sig = SIGRTMIN; sig <= SIGRTMAX; ++sig) v.push_back(sig);
    return v;
}

void install_signal_cleanup() {
    current_umask();
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_terminating_signal;
    sa.sa_flags = SA_RESTART;  // a deferred request returns: system calls then carry on
    sigemptyset(&sa.sa_mask);
    // Termination requests, crashes, broken pipes, timers, user signals: none may leave a
    // temporary file behind. A signal the parent set to be ignored (nohup) stays ignored.
    for (int sig : terminating_signals()) {
        struct sigaction old;
        if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN && sig != SIGSEGV &&
            sig != SIGBUS && sig != SIGFPE && sig != SIGILL && sig != SIGABRT)
            continue;
        ::sigaction(sig, &sa, nullptr);
    }
    ::signal(SIGXFSZ, SIG_IGN);
}

void defer_termination_requests() { g_defer.store(true); }

int termination_requested() { return g_requested.load(); }

std::string signal_name(int sig) {
    switch (sig) {
        case SIGTERM:
            return "SIGTERM";
        case SIGINT:
            return "SIGINT";
        case SIGHUP:
            return "SIGHUP";
        case SIGQUIT:
            return "SIGQUIT";
        default:
            return "signal " + std::to_string(sig);
    }
}

void end_by_signal(int sig) {
    g_defer.store(false);
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, sig);
    ::pthread_sigmask(SIG_UNBLOCK, &set, nullptr);
    cleanup_and_reraise(sig);
    ::_exit(128 + sig);  // not reached: the signal's default action ends the process
}

namespace {

// "N" when s is a whole decimal number of at most 9 digits (a descriptor), else -1.
int small_number(const std::string& s) {
    if (s.empty() || s.size() > 9) return -1;
    for (char c : s)
        if (c < '0' || c > '9') return -1;
    return std::stoi(s);
}

// The descriptor that an absolute, link-free spelling names, or -1.
int fd_named_by(const std::string& p) {
    if (p == "/dev/stdout") return 1;
    if (p == "/dev/stderr") return 2;
    if (p == "/dev/stdin") return 0;
    for (const std::string& prefix :
         {std::string("/dev/fd/"), std::string("/proc/self/fd/"),
          std::string("/proc/thread-self/fd/"), "/proc/" + std::to_string(::getpid()) + "/fd/"})
        if (p.compare(0, prefix.size(), prefix) == 0) return small_number(p.substr(prefix.size()));
    return -1;
}

// "a/./b//c/../d" -> "a/d" on the text alone (after a link, ".." is taken on the link's text, as
// the names above are only ever reached that way).
std::string lexically_normal(const std::string& p) {
    std::string n = std::filesystem::path(p).lexically_normal().string();
    if (n.size() > 1 && n.back() == '/') n.pop_back();
    return n;
}

// Follows the links of `path` by their text: calls step(spelling) with each absolute spelling, the
// given one first, stopping when step returns true; returns the last spelling. At most 40 links
// (the kernel's own limit); a loop is left to the caller's stat to report.
template <class Step>
std::string follow_links(const std::string& path, Step step) {
    namespace fs = std::filesystem;
    std::error_code ec;
    std::string p = path;
    if (p.empty() || p[0] != '/') p = (fs::current_path(ec) / p).string();
    p = lexically_normal(p);
    for (int hop = 0; hop <= 40; ++hop) {
        if (step(p)) return p;
        // Resolve every folder of the spelling, then look at its last name alone.
        const fs::path fp(p);
        fs::path dir = fs::weakly_canonical(fp.parent_path(), ec);
        if (ec) return p;
        const std::string here = (dir / fp.filename()).string();
        if (here != p && step(here)) return here;
        struct stat st;
        if (::lstat(here.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return here;
        std::vector<char> buf(PATH_MAX + 1);
        const ssize_t n = ::readlink(here.c_str(), buf.data(), buf.size() - 1);
        if (n <= 0) return here;
        const std::string text(buf.data(), static_cast<size_t>(n));
        p = lexically_normal(text[0] == '/' ? text : (dir / text).string());
    }
    return p;
}

// The descriptors open when main started (note_inherited_descriptors); empty: not recorded.
constexpr int kInheritedMax = 1024;
std::vector<bool> g_inherited;

// The descriptor the path's spelling names (before standard error is mapped), or -1.
int named_fd(const std::string& path) {
    int fd = -1;
    follow_links(path, [&](const std::string& p) {
        fd = fd_named_by(p);
        return fd >= 0;
    });
    return fd;
}

}  // namespace

void note_inherited_descriptors() {
    g_inherited.assign(kInheritedMax, false);
    for (int fd = 0; fd < kInheritedMax; ++fd) g_inherited[fd] = ::fcntl(fd, F_GETFD) != -1;
}

int stream_fd_of(const std::string& path) {
    const int fd = named_fd(path);
    // Descriptor 2 carries the libraries' messages through a filter: the user's stream is the
    // real stderr behind it.
    return fd == 2 ? real_stderr_descriptor() : fd;
}

std::string stdout_as_dash(const std::string& path) {
    return path != "-" && stream_fd_of(path) == 1 ? "-" : path;
}

std::string output_landing(const std::string& path) {
    struct stat st;
    if (::lstat(path.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return path;
    struct stat target;
    if (::stat(path.c_str(), &target) != 0)
        throw Error(path + ": is a link to " + (errno == ELOOP ? "itself (a loop)" : "nothing") +
                    "; refusing to write through it");
    return follow_links(path, [](const std::string&) { return false; });
}

void check_output_path(const std::string& path, bool stream_ok) {
    if (const int fd = stream_fd_of(path); fd >= 0) {
        const std::string what = fd == 1 ? "standard output"
                                 : fd == real_stderr_descriptor()
                                     ? "standard error"
                                     : "descriptor " + std::to_string(fd);
        if (!stream_ok)
            throw Error(path + ": names a stream (" + what +
                        "); this output must be a file: name a regular file");
        const int named = named_fd(path);
        if (!g_inherited.empty() &&
            (named >= kInheritedMax || !g_inherited[static_cast<size_t>(named)]))
            throw Error(path + ": names descriptor " + std::to_string(named) +
                        ", which spectex was not given (one it opens itself, such as an output "
                        "being written); name a stream the shell passed, or a file");
        const int flags = ::fcntl(fd, F_GETFL);
        if (flags < 0 || (flags & O_ACCMODE) == O_RDONLY)
            throw Error(path + ": names " + what + ", which is not open for writing");
        return;
    }
    const std::string base = path.substr(path.find_last_of('/') + 1);
    long name_max = ::pathconf(folder_of(path).c_str(), _PC_NAME_MAX);
    if (name_max <= 0) name_max = NAME_MAX;
    if (base.size() > static_cast<size_t>(name_max))
        throw Error(path + ": the file name is " + std::to_string(base.size()) +
                    " bytes, longer than the " + std::to_string(name_max) + " its folder allows");
    if (path.size() >= PATH_MAX)
        throw Error(path + ": the path is longer than " + std::to_string(PATH_MAX - 1) + " bytes");
    struct stat st;
    if (::lstat(path.c_str(), &st) != 0) return;  // nothing there yet
    if (S_ISREG(st.st_mode)) return;
    if (S_ISLNK(st.st_mode)) {
        // A link to a regular file is written through (output_landing): the link stays, its
        // target is replaced. A dangling link or a link loop is refused there.
        struct stat target;
        if (::stat(path.c_str(), &target) != 0) {
            output_landing(path);  // throws, naming the cause
            return;
        }
        if (S_ISREG(target.st_mode)) return;
        throw Error(path + ": is a link to " + file_kind(target.st_mode) +
                    "; refusing to replace it with an output");
    }
    throw Error(path + ": is " + file_kind(st.st_mode) +
                ", not a regular file; refusing to replace it with an output");
}

AtomicFile::AtomicFile(const std::string& final_path) : final_(final_path) {
    check_output_path(final_path);
    landing_ = output_landing(final_path);
    std::string dir = folder_of(landing_);
    std::string base = landing_.substr(landing_.find_last_of('/') + 1);
    // The temporary name adds 19 bytes: shorten the name part so that it fits the folder's name
    // limit whenever the final name does.
    static const std::string suffix = ".spectex-XXXXXX.tmp";
    long name_max = ::pathconf(dir.c_str(), _PC_NAME_MAX);
    if (name_max <= 0) name_max = NAME_MAX;
    if (base.size() + suffix.size() > static_cast<size_t>(name_max))
        base.resize(static_cast<size_t>(name_max) > suffix.size()
                        ? static_cast<size_t>(name_max) - suffix.size()
                        : 0);
    std::string tmpl =
        (dir == "." && landing_.find('/') == std::string::npos ? "" : dir + "/") + base + suffix;
    std::vector<char> buf(tmpl.begin(), tmpl.end());
    buf.push_back('\0');
    current_umask();
    fd_ = ::mkstemps(buf.data(), 4);
    if (fd_ < 0)
        throw Error(final_path + ": cannot create a temporary file in " + dir + ": " +
                    std::strerror(errno));
    temp_ = buf.data();
    slot_ = take_slot(temp_);
}

AtomicFile::~AtomicFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_) ::unlink(temp_.c_str());
    release_slot(slot_);
}

void AtomicFile::commit() {
    auto fail = [&](const char* what) {
        throw Error(final_ + ": " + what + ": " + std::strerror(errno));
    };
    if (::fsync(fd_) != 0) fail("fsync failed");
    if (::fchmod(fd_, 0666 & ~current_umask()) != 0) fail("cannot set the file mode");
    int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) fail("close failed");
    // What the constructor saw may have changed meanwhile; the landing is never a link.
    check_output_path(landing_);
    struct stat st;
    if (::lstat(landing_.c_str(), &st) == 0 && S_ISLNK(st.st_mode)) {
        errno = EEXIST;
        fail("a link appeared where the output lands; not replacing it");
    }
    if (::rename(temp_.c_str(), landing_.c_str()) != 0) fail("cannot rename the temporary file");
    committed_ = true;
    int dfd = ::open(folder_of(landing_).c_str(), O_RDONLY | O_DIRECTORY);
    if (dfd >= 0) {
        ::fsync(dfd);  // best effort: makes the rename durable
        ::close(dfd);
    }
}

}  // namespace spectex

namespace spectex {

void write_all(int fd, const std::string& text, const std::string& path) {
    size_t done = 0;
    while (done < text.size()) {
        ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) throw Error(path + ": write failed: " + std::strerror(n < 0 ? errno : EIO));
        done += static_cast<size_t>(n);
    }
}

void write_text_atomically(const std::string& path, const std::string& text) {
    if (const int fd = stream_fd_of(path); fd >= 0) {
        check_output_path(path, true);
        write_all(fd, text, path);
        return;
    }
    AtomicFile f(path);
    write_all(f.fd(), text, path);
    f.commit();
}

void make_folders(const std::string& dir, const std::string& what) {
    if (dir.empty()) return;
    for (size_t pos = 0; pos != std::string::npos;) {
        pos = dir.find('/', pos + 1);
        const std::string partial = dir.substr(0, pos);
        if (partial.empty() || partial.back() == '/') continue;
        if (::mkdir(partial.c_str(), 0777) == 0) continue;
        const int err = errno;
        struct stat st;
        if (err == EEXIST && ::stat(partial.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) continue;
        throw Error(partial + ": cannot create " + what + ": " +
                    (err == EEXIST ? std::string("something that is not a folder is there")
                                   : std::strerror(err)));
    }
}

}  // namespace spectex

namespace spectex {

std::string store_file_in_folder(const std::string& dir, const std::string& name,
                                 const std::string& text) {
    try {
        make_folders(dir, "the cache folder");
    } catch (const Error& e) {
        return e.what();
    }
    std::string temp = dir + "/." + name + ".XXXXXX";
    std::vector<char> buf(temp.begin(), temp.end());
    buf.push_back('\0');
    const int fd = ::mkstemp(buf.data());
    if (fd < 0) return dir + ": cannot create a file there: " + std::strerror(errno);
    temp.assign(buf.data());
    const int slot = take_slot(temp);
    std::string cause;
    try {
        write_all(fd, text, temp);
    } catch (const Error& e) {
        cause = e.what();
    }
    if (cause.empty() && ::fchmod(fd, 0666 & ~current_umask()) != 0)
        cause = temp + ": " + std::strerror(errno);
    if (cause.empty() && ::fsync(fd) != 0) cause = temp + ": " + std::strerror(errno);
    if (::close(fd) != 0 && cause.empty()) cause = temp + ": " + std::strerror(errno);
    const std::string final_path = dir + "/" + name;
    if (cause.empty() && ::rename(temp.c_str(), final_path.c_str()) != 0)
        cause = final_path + ": " + std::strerror(errno);
    if (!cause.empty()) ::unlink(temp.c_str());
    release_slot(slot);
    return cause;
}

bool read_small_regular_file(const std::string& path, size_t max_bytes, std::string* text) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return false;
    struct stat st;
    bool ok = ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size >= 0 &&
              static_cast<uint64_t>(st.st_size) <= max_bytes;
    std::string out;
    if (ok) {
        out.resize(static_cast<size_t>(st.st_size));
        size_t got = 0;
        while (ok && got < out.size()) {
            const ssize_t n = ::read(fd, &out[got], out.size() - got);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0)
                ok = false;
            else
                got += static_cast<size_t>(n);
        }
        char extra;
        // A file that grew since fstat is not the entry that was measured.
        if (ok && ::read(fd, &extra, 1) != 0) ok = false;
    }
    ::close(fd);
    if (ok) *text = std::move(out);
    return ok;
}

}  // namespace spectex
