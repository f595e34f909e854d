#include "io/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <cstring>
#include <mutex>
#include <vector>

#include "io/paths.h"
#include "spectral/bounded_read.h"
#include "spectral/error.h"

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
    sa.sa_handler = cleanup_and_reraise;
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

void check_output_path(const std::string& path) {
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
        struct stat target;
        // A link to a regular file (or a dangling one) is replaced by the rename; its target is
        // untouched.
        if (::stat(path.c_str(), &target) != 0 || S_ISREG(target.st_mode)) return;
        throw Error(path + ": is a link to " + file_kind(target.st_mode) +
                    "; refusing to replace it with an output");
    }
    throw Error(path + ": is " + file_kind(st.st_mode) +
                ", not a regular file; refusing to replace it with an output");
}

AtomicFile::AtomicFile(const std::string& final_path) : final_(final_path) {
    check_output_path(final_path);
    std::string dir = folder_of(final_path);
    std::string base = final_path.substr(final_path.find_last_of('/') + 1);
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
        (dir == "." && final_path.find('/') == std::string::npos ? "" : dir + "/") + base + suffix;
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
    check_output_path(final_);  // what the constructor saw may have changed meanwhile
    if (::rename(temp_.c_str(), final_.c_str()) != 0) fail("cannot rename the temporary file");
    committed_ = true;
    int dfd = ::open(folder_of(final_).c_str(), O_RDONLY | O_DIRECTORY);
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
    AtomicFile f(path);
    write_all(f.fd(), text, path);
    f.commit();
}

void make_folders(const std::string& dir) {
    if (dir.empty()) return;
    for (size_t pos = 0; pos != std::string::npos;) {
        pos = dir.find('/', pos + 1);
        const std::string partial = dir.substr(0, pos);
        if (partial.empty() || partial.back() == '/') continue;
        if (::mkdir(partial.c_str(), 0777) == 0) continue;
        const int err = errno;
        struct stat st;
        if (err == EEXIST && ::stat(partial.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) continue;
        throw Error(partial + ": cannot create the output folder: " +
                    (err == EEXIST ? std::string("something that is not a folder is there")
                                   : std::strerror(err)));
    }
}

}  // namespace spectex
