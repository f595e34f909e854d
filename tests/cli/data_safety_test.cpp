// No lost data: killed runs, file-size limits and full disks never leave a file under the final
// name (nor a half-written one), SIGTERM removes the temporary file, outputs respect the umask,
// and output bytes do not depend on the run or the thread count.
//
// About SIGKILL: it cannot be caught, so the temporary file (<output>.spectex-XXXXXX.tmp) of a
// killed run stays behind in the output folder. The guarantee is only that the final name never
// holds a partial file (and that a previous file under that name is untouched).
#include <ImfAttribute.h>
#include <ImfIO.h>
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

bool contains(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

// A spectex child with optional working folder, umask and file-size limit; stdout and stderr go to
// files. Only async-signal-safe calls run between fork and exec (the test process has threads).
struct Child {
    pid_t pid = -1;
    std::string out_path, err_path;
    int status = -1;  // exit status, or 128+signal
    std::string out, err;
};

struct ChildOptions {
    std::string cwd;
    int umask_bits = -1;
    rlim_t fsize_limit = RLIM_INFINITY;
};

Child start_spectex(const ScratchDir& io, const std::vector<std::string>& args,
                    const ChildOptions& opt = {}) {
    Child c;
    c.out_path = io / "child.out";
    c.err_path = io / "child.err";
    std::vector<std::string> argv_s = spectex_argv(args);
    std::vector<char*> argv = c_array(argv_s);
    struct rlimit lim {
        opt.fsize_limit, opt.fsize_limit
    };
    c.pid = fork();
    if (c.pid == 0) {
        int fo = ::open(c.out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
        int fe = ::open(c.err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
        if (fo < 0 || fe < 0) _exit(125);
        dup2(fo, 1);
        dup2(fe, 2);
        // Default dispositions and an empty mask, whatever the test runner had.
        sigset_t none;
        sigemptyset(&none);
        sigprocmask(SIG_SETMASK, &none, nullptr);
        for (int sig = 1; sig < NSIG; ++sig) signal(sig, SIG_DFL);
        if (!opt.cwd.empty() && chdir(opt.cwd.c_str()) != 0) _exit(126);
        if (opt.umask_bits >= 0) umask(static_cast<mode_t>(opt.umask_bits));
        if (opt.fsize_limit != RLIM_INFINITY && setrlimit(RLIMIT_FSIZE, &lim) != 0) _exit(123);
        execv(argv[0], argv.data());
        const char msg[] = "test harness: execv failed\n";
        (void)!write(2, msg, sizeof msg - 1);
        _exit(127);
    }
    return c;
}

void finish(Child& c) {
    int st = 0;
    if (c.pid > 0 && waitpid(c.pid, &st, 0) == c.pid)
        c.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    c.out = read_file(c.out_path);
    c.err = read_file(c.err_path);
}

Child run(const std::vector<std::string>& args, const ChildOptions& opt = {}) {
    ScratchDir io;
    Child c = start_spectex(io, args, opt);
    finish(c);
    return c;
}

off_t size_of(const std::string& p) {
    struct stat st;
    return ::stat(p.c_str(), &st) == 0 ? st.st_size : -1;
}

// A noisy 8-bit RGB PNG (incompressible, so the bake cannot be quick).
void write_noise_png(const std::string& path, int w, int h, unsigned seed = 42) {
    std::mt19937 rng(seed);
    std::vector<uint8_t> px(static_cast<size_t>(w) * static_cast<size_t>(h) * 3);
    for (auto& v : px) v = static_cast<uint8_t>(rng() & 0xff);
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
}

// Starts a bake of a large input and sends `sig` once its temporary file holds more than
// `min_bytes`. Returns the finished child; *tmp_seen is the temporary file's name.
Child bake_and_kill(const ScratchDir& d, const std::string& in, const std::string& out, int sig,
                    off_t min_bytes, std::string* tmp_seen, off_t* tmp_size_at_kill,
                    bool final_absent = true) {
    ScratchDir io;
    Child c = start_spectex(io, {"bake", in, "-o", out, "--compression", "none", "--threads", "1"});
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    bool sent = false;
    while (std::chrono::steady_clock::now() < deadline) {
        int st;
        if (waitpid(c.pid, &st, WNOHANG) == c.pid) {  // finished before we could kill it
            c.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
            c.pid = -1;
            break;
        }
        auto tmp = temp_files_in(d.path());
        if (!tmp.empty()) {
            off_t sz = size_of(d / tmp.front());
            if (sz > min_bytes) {
                *tmp_seen = tmp.front();
                *tmp_size_at_kill = sz;
                // The final name must not exist while the temporary file is being written.
                if (final_absent)
                    EXPECT_FALSE(file_exists(out)) << "final name exists during the write";
                kill(c.pid, sig);
                sent = true;
                break;
            }
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    if (!sent && c.pid > 0) kill(c.pid, SIGKILL);
    finish(c);
    EXPECT_TRUE(sent) << "the temporary file never grew past " << min_bytes << " bytes; stderr:\n"
                      << c.err;
    return c;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Killed in the middle of a large write (4096x2048 input: 1.36 GB of half samples uncompressed).

TEST(DataSafety, SigtermMidWriteLeavesNothing) {
    ScratchDir d;
    const std::string in = d / "big.png", out = d / "big.exr";
    write_noise_png(in, 4096, 2048);
    std::string tmp;
    off_t at = 0;
    Child c = bake_and_kill(d, in, out, SIGTERM, 8 << 20, &tmp, &at);
    EXPECT_FALSE(tmp.empty());
    EXPECT_EQ(tmp.rfind("big.exr.spectex-", 0), 0u) << tmp;
    EXPECT_NE(c.status, 0) << "killed bake reported success";
    EXPECT_FALSE(file_exists(out)) << "a file exists under the final name after SIGTERM";
    auto left = temp_files_in(d.path());
    EXPECT_TRUE(left.empty()) << "temporary file left after SIGTERM: "
                              << (left.empty() ? "" : left.front());
    std::printf("  SIGTERM at %lld bytes of %s: status %d, stderr: %s\n",
                static_cast<long long>(at), tmp.c_str(), c.status, c.err.c_str());
}

TEST(DataSafety, SigkillMidWriteNeverTouchesTheFinalName) {
    ScratchDir d;
    const std::string in = d / "big.png", out = d / "big.exr";
    write_noise_png(in, 4096, 2048);
    std::string tmp;
    off_t at = 0;
    Child c = bake_and_kill(d, in, out, SIGKILL, 8 << 20, &tmp, &at);
    EXPECT_EQ(c.status, 128 + SIGKILL);
    EXPECT_FALSE(file_exists(out)) << "a file exists under the final name after SIGKILL";
    // SIGKILL cannot be caught: the temporary may remain (documented); nothing else may appear.
    for (const auto& n : list_dir(d.path()))
        EXPECT_TRUE(n == "big.png" || n == tmp) << "unexpected file after SIGKILL: " << n;
}

TEST(DataSafety, SigtermKeepsAPreviousOutputIntact) {
    // A re-bake that is interrupted leaves the previous output exactly as it was.
    ScratchDir d;
    const std::string in = d / "big.png", out = d / "big.exr";
    write_noise_png(in, 4096, 2048);
    write_image(out, 2, 2, 3, OIIO::TypeDesc::UINT8, std::vector<uint8_t>(12, 7).data());
    const std::string before = read_file(out);
    for (int sig : {SIGTERM, SIGINT, SIGHUP, SIGKILL}) {
        std::string tmp;
        off_t at = 0;
        Child c = bake_and_kill(d, in, out, sig, 4 << 20, &tmp, &at, false);
        EXPECT_NE(c.status, 0) << strsignal(sig);
        EXPECT_EQ(read_file(out), before)
            << "previous output changed by a bake killed with " << strsignal(sig);
        if (sig != SIGKILL) EXPECT_TRUE(temp_files_in(d.path()).empty()) << strsignal(sig);
        for (const auto& t : temp_files_in(d.path())) ::unlink((d / t).c_str());
    }
}

// A batch pre-empted by a farm (SIGTERM), stopped with Ctrl-C (SIGINT) or left by its terminal or
// ssh session (SIGHUP; it ended the batch with no report at all): it starts no new file,
// the file being baked stops and its temporary file is removed, the --json report keeps a record
// of each file finished and ends with one saying the run was interrupted by that signal, the last
// line on stderr names the signal, and the process ends by the signal (128 + N in a shell).
// Six 512x512 files with --jobs 1 (each about 0.1 s here, 1 s under the sanitizers); the signal
// goes once the first output exists, so at least one file is finished and most are not.
TEST(DataSafety, AnInterruptedBatchKeepsTheRecordsOfTheFilesItFinished) {
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) {
        ScratchDir d;
        std::vector<std::string> args{"bake"};
        for (int i = 0; i < 6; ++i) {
            const std::string in = d / ("t" + std::to_string(i) + ".png");
            write_noise_png(in, 512, 512, static_cast<unsigned>(i + 1));
            args.push_back(in);
        }
        args.insert(args.end(), {"--output-dir", d / "out", "--method", "basis", "--jobs", "1",
                                 "--threads", "1", "--json", d / "report.jsonl"});
        ScratchDir io;
        Child c = start_spectex(io, args);
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
        bool sent = false;
        while (!sent && std::chrono::steady_clock::now() < deadline) {
            if (file_exists(d / "out/t0.exr")) {
                kill(c.pid, sig);
                sent = true;
            } else {
                std::this_thread::sleep_for(std::chrono::milliseconds(1));
            }
        }
        finish(c);
        ASSERT_TRUE(sent) << "the first output never appeared: " << c.err;
        EXPECT_EQ(c.status, 128 + sig) << "not ended by " << strsignal(sig) << ": " << c.err;
        // The records: one per finished file, each with its output there, then the interruption.
        const std::string report = read_file(d / "report.jsonl");
        std::vector<std::string> lines;
        std::istringstream in(report);
        for (std::string line; std::getline(in, line);) lines.push_back(line);
        ASSERT_GE(lines.size(), 2u) << report << "\nstderr:\n" << c.err;
        const std::string name = sig == SIGTERM ? "SIGTERM" : sig == SIGINT ? "SIGINT" : "SIGHUP";
        const std::string last = lines.back();
        EXPECT_TRUE(contains(last, "\"status\":\"interrupted\"")) << last;
        EXPECT_TRUE(contains(last, "\"signal\":\"" + name + "\"")) << last;
        EXPECT_TRUE(contains(last, "\"files\":6")) << last;
        const size_t finished = lines.size() - 1;
        EXPECT_TRUE(contains(last, "\"finished\":" + std::to_string(finished))) << last;
        EXPECT_LT(finished, 6u) << "the signal came after the last file: nothing was interrupted";
        size_t outputs = 0;
        for (size_t i = 0; i + 1 < lines.size(); ++i) {
            EXPECT_TRUE(contains(lines[i], "\"status\":\"ok\"")) << lines[i];
            const std::string out = d / ("out/t" + std::to_string(i) + ".exr");
            EXPECT_TRUE(contains(lines[i], "\"output\":\"" + out + "\"")) << lines[i];
            EXPECT_EQ(read_exr(out).width, 512) << out;
        }
        for (const auto& n : list_dir(d / "out")) ++outputs, (void)n;
        EXPECT_EQ(outputs, finished) << "an output without a record, or a file left behind";
        EXPECT_TRUE(temp_files_in(d / "out").empty()) << "a temporary file left after " << name;
        EXPECT_TRUE(temp_files_in(d.path()).empty()) << "the report's temporary file left";
        // The last line on stderr names the signal.
        std::string err = c.err;
        while (!err.empty() && err.back() == '\n') err.pop_back();
        const std::string last_err = err.substr(err.rfind('\n') + 1);
        EXPECT_TRUE(contains(last_err, "interrupted by " + name)) << c.err;
    }
}

TEST(DataSafety, EverySignalThatEndsTheProcessRemovesTheTemporaryFile) {
    // Broken pipes, timers, user signals, CPU limits, real-time signals: whatever ends the process
    // must not leave its temporary file. SIGXFSZ is ignored on purpose (the write then fails with
    // EFBIG and is reported): that run must end without a temporary file too.
    ScratchDir d;
    const std::string in = d / "big.png", out = d / "big.exr";
    write_noise_png(in, 4096, 1024);
    for (int sig : {SIGPIPE, SIGUSR1, SIGUSR2, SIGALRM, SIGVTALRM, SIGXCPU, SIGPROF, SIGIO, SIGPWR,
                    SIGSYS, SIGTRAP, SIGSTKFLT, SIGRTMIN, SIGRTMAX, SIGXFSZ}) {
        std::string tmp;
        off_t at = 0;
        Child c = bake_and_kill(d, in, out, sig, 1 << 20, &tmp, &at);
        EXPECT_FALSE(tmp.empty()) << strsignal(sig);
        if (sig == SIGXFSZ)
            EXPECT_EQ(c.status, 0) << "SIGXFSZ is ignored; the bake goes on: " << c.err;
        else
            EXPECT_EQ(c.status, 128 + sig)
                << strsignal(sig) << " did not end the run with its own status: " << c.err;
        auto left = temp_files_in(d.path());
        EXPECT_TRUE(left.empty()) << "temporary file left after " << strsignal(sig) << ": "
                                  << left.front();
        for (const auto& t : left) ::unlink((d / t).c_str());
        ::unlink(out.c_str());
    }
}

TEST(DataSafety, AClosedStandardOutputLeavesNoTemporaryFile) {
    // `spectex bake ... --json - | head -c 1`: the reader goes away while files are still baking.
    ScratchDir d;
    std::vector<std::string> args = {
        "bake", "--json", "-", "--jobs", "2", "-o", d.path() + "/{stem}.exr"};
    for (int i = 0; i < 6; ++i) {
        write_noise_png(d / ("in" + std::to_string(i) + ".png"), 1024, 512,
                        7 + static_cast<unsigned>(i));
        args.push_back(d / ("in" + std::to_string(i) + ".png"));
    }
    std::vector<std::string> argv_s = spectex_argv(args);
    std::vector<char*> argv = c_array(argv_s);
    int p[2];
    ASSERT_EQ(::pipe(p), 0);
    pid_t pid = fork();
    if (pid == 0) {
        for (int sig = 1; sig < NSIG; ++sig) signal(sig, SIG_DFL);
        dup2(p[1], 1);
        ::close(p[0]);
        ::close(p[1]);
        int devnull = ::open("/dev/null", O_WRONLY);
        dup2(devnull, 2);
        execv(argv[0], argv.data());
        _exit(127);
    }
    ::close(p[1]);
    char byte;
    ASSERT_EQ(::read(p[0], &byte, 1), 1);  // the first record has started: then the reader leaves
    ::close(p[0]);
    int st = 0;
    ASSERT_EQ(waitpid(pid, &st, 0), pid);
    EXPECT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGPIPE) << "status " << st;
    EXPECT_TRUE(temp_files_in(d.path()).empty())
        << "temporary file left: " << temp_files_in(d.path()).front();
}

// ---------------------------------------------------------------------------------------------
// File-size limit and a full filesystem.

TEST(DataSafety, FileSizeLimitIsAnErrorNotASignal) {
    ScratchDir d;
    const std::string in = d / "in.png", out = d / "out.exr";
    write_noise_png(in, 512, 512);  // 42 MB of uncompressed half samples
    ChildOptions opt;
    opt.fsize_limit = 1 << 20;
    Child c = run({"bake", in, "-o", out, "--compression", "none"}, opt);
    EXPECT_NE(c.status, 128 + SIGXFSZ) << "killed by SIGXFSZ";
    EXPECT_EQ(c.status, 1) << c.err;
    EXPECT_EQ(c.err.rfind("spectex: " + out + ": ", 0), 0u) << c.err;
    EXPECT_TRUE(contains(c.err, "File too large")) << c.err;
    EXPECT_FALSE(file_exists(out));
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(DataSafety, FileSizeLimitKeepsAPreviousOutputIntact) {
    ScratchDir d;
    const std::string in = d / "in.png", out = d / "out.exr";
    write_noise_png(in, 512, 512);
    std::ofstream(out, std::ios::binary) << "previous output";
    ChildOptions opt;
    opt.fsize_limit = 1 << 20;
    Child c = run({"bake", in, "-o", out, "--compression", "none"}, opt);
    EXPECT_EQ(c.status, 1) << c.err;
    EXPECT_EQ(read_file(out), "previous output");
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(DataSafety, FullFilesystem) {
    // A 2 MB tmpfs (tests run as root). Where mounting is not permitted the test is skipped and the
    // file-size-limit tests above cover the same code path (a failing write()).
    ScratchDir d;
    const std::string mnt = d / "mnt";
    ASSERT_EQ(::mkdir(mnt.c_str(), 0755), 0);
    if (::mount("tmpfs", mnt.c_str(), "tmpfs", 0, "size=2m") != 0)
        GTEST_SKIP() << "cannot mount a tmpfs here: " << std::strerror(errno);
    struct Unmount {
        std::string p;
        ~Unmount() { ::umount2(p.c_str(), MNT_DETACH); }
    } unmount{mnt};
    const std::string in = d / "in.png", out = mnt + "/out.exr";
    write_noise_png(in, 512, 512);
    Child c = run({"bake", in, "-o", out, "--compression", "none"});
    EXPECT_EQ(c.status, 1) << c.err;
    EXPECT_EQ(c.err.rfind("spectex: " + out + ": ", 0), 0u) << c.err;
    EXPECT_TRUE(contains(c.err, "No space left on device")) << c.err;
    EXPECT_TRUE(list_dir(mnt).empty()) << "left in the full filesystem: " << list_dir(mnt).front();
    // And a small output still fits afterwards (the space was given back).
    write_noise_png(in, 8, 8);
    Child ok = run({"bake", in, "-o", out});
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_TRUE(file_exists(out));
}

TEST(DataSafety, AReportThatDoesNotFitIsAFailure) {
    // --json on a full filesystem: the report is incomplete, so the run fails and leaves no report
    // (nor a temporary one); the baked files themselves are elsewhere and fine.
    ScratchDir d;
    const std::string mnt = d / "mnt";
    ASSERT_EQ(::mkdir(mnt.c_str(), 0755), 0);
    if (::mount("tmpfs", mnt.c_str(), "tmpfs", 0, "size=4k") != 0)
        GTEST_SKIP() << "cannot mount a tmpfs here: " << std::strerror(errno);
    struct Unmount {
        std::string p;
        ~Unmount() { ::umount2(p.c_str(), MNT_DETACH); }
    } unmount{mnt};
    std::vector<std::string> args = {
        "bake", "-q", "--json", mnt + "/report.jsonl", "-o", d.path() + "/{stem}.exr"};
    for (int i = 0; i < 24; ++i) {  // 24 records of about 600 bytes: more than the 4 kB filesystem
        const std::string in = d / ("in" + std::to_string(i) + ".png");
        write_noise_png(in, 4, 4, static_cast<unsigned>(i));
        args.push_back(in);
    }
    Child c = run(args);
    EXPECT_EQ(c.status, 1) << c.err;
    EXPECT_TRUE(contains(c.err, "No space left on device")) << c.err;
    EXPECT_TRUE(contains(c.err, "report.jsonl")) << c.err;
    EXPECT_TRUE(list_dir(mnt).empty()) << "left in the full filesystem: " << list_dir(mnt).front();
}

// ---------------------------------------------------------------------------------------------
// Umask.

TEST(DataSafety, OutputModeFollowsTheUmask) {
    const std::pair<int, mode_t> cases[] = {
        {027, 0640}, {022, 0644}, {077, 0600}, {002, 0664}, {0, 0666}};
    for (auto [mask, want] : cases) {
        ScratchDir d;
        const std::string in = d / "in.png", out = d / "out.exr";
        write_noise_png(in, 4, 4);
        ChildOptions opt;
        opt.umask_bits = mask;
        Child c = run({"bake", in, "-o", out}, opt);
        ASSERT_EQ(c.status, 0) << c.err;
        struct stat st;
        ASSERT_EQ(::stat(out.c_str(), &st), 0);
        EXPECT_EQ(st.st_mode & 07777, want)
            << "umask " << std::oct << mask << " gave " << (st.st_mode & 07777);
    }
}

// ---------------------------------------------------------------------------------------------
// Determinism.

namespace {

// An Imf::OStream into a string, to compare attribute values of any type.
class StringOStream : public Imf::OStream {
  public:
    StringOStream() : Imf::OStream("memory") {}
    void write(const char c[], int n) override { s_.append(c, static_cast<size_t>(n)); }
    uint64_t tellp() override { return s_.size(); }
    void seekp(uint64_t) override {}
    const std::string& str() const { return s_; }

  private:
    std::string s_;
};

std::string attribute_bytes(const Imf::Attribute& a) {
    StringOStream s;
    a.writeValueTo(s, 2);
    return s.str();
}

// Everything but spectex:commandLine: windows, channels and their types, every pixel bit, every
// other attribute's type and value.
void expect_same_exr_except_command_line(const std::string& pa, const std::string& pb) {
    ExrImage a = read_exr(pa), b = read_exr(pb);
    EXPECT_EQ(a.data_window, b.data_window);
    EXPECT_EQ(a.display_window, b.display_window);
    ASSERT_EQ(a.channel_names, b.channel_names);
    for (const auto& n : a.channel_names) {
        EXPECT_EQ(a.types.at(n), b.types.at(n)) << n;
        const auto &va = a.pixels.at(n), &vb = b.pixels.at(n);
        ASSERT_EQ(va.size(), vb.size());
        EXPECT_EQ(std::memcmp(va.data(), vb.data(), va.size() * sizeof(float)), 0)
            << "channel " << n << " differs";
    }
    std::vector<std::string> names_a, names_b;
    for (auto it = a.header.begin(); it != a.header.end(); ++it) names_a.push_back(it.name());
    for (auto it = b.header.begin(); it != b.header.end(); ++it) names_b.push_back(it.name());
    EXPECT_EQ(names_a, names_b);
    for (auto it = a.header.begin(); it != a.header.end(); ++it) {
        const std::string name = it.name();
        if (name == "spectex:commandLine") continue;
        const Imf::Attribute* other =
            b.header.find(name) == b.header.end() ? nullptr : &b.header[name];
        if (!other) continue;
        EXPECT_STREQ(it.attribute().typeName(), other->typeName()) << name;
        EXPECT_EQ(attribute_bytes(it.attribute()), attribute_bytes(*other))
            << "attribute " << name << " differs";
    }
}

void write_rgba16(const std::string& path, int w, int h) {
    std::mt19937 rng(99);
    std::vector<uint16_t> px(static_cast<size_t>(w * h * 4));
    for (auto& v : px) v = static_cast<uint16_t>(rng() & 0xffff);
    write_image(path, w, h, 4, OIIO::TypeDesc::UINT16, px.data());
}

}  // namespace

TEST(DataSafety, SameCommandTwiceIsByteIdentical) {
    // Same arguments, same folder, same thread count: the files are the same bytes (there is no
    // timestamp in the header).
    ScratchDir d;
    write_rgba16(d / "in.png", 301, 257);
    for (const char* comp : {"zip", "piz", "none"}) {
        for (const char* threads : {"1", "2"}) {
            std::vector<std::string> args{"bake",          "in.png", "-o",        "out.exr",
                                          "--compression", comp,     "--threads", threads};
            ChildOptions opt;
            opt.cwd = d.path();
            Child a = run(args, opt);
            ASSERT_EQ(a.status, 0) << a.err;
            ASSERT_EQ(::rename((d / "out.exr").c_str(), (d / "first.exr").c_str()), 0);
            Child b = run(args, opt);
            ASSERT_EQ(b.status, 0) << b.err;
            EXPECT_TRUE(read_file(d / "first.exr") == read_file(d / "out.exr"))
                << "two runs of the same command differ (" << comp << ", --threads " << threads
                << ")";
        }
    }
}

TEST(DataSafetySlow, ThreadCountDoesNotChangeTheOutput) {
    // --threads 1, 2 and 4 give the same pixels and header, save spectex:commandLine (which records
    // the arguments). As "--threads 1" and "--threads 2" have the same length, the files are also
    // byte-identical once that text is patched.
    ScratchDir d;
    write_rgba16(d / "in.png", 1031,
                 517);  // several strips and chunks with zip (16 lines) and piz (32)
    for (const char* comp : {"zip", "piz", "dwaa"}) {
        std::vector<std::string> files;
        for (const char* threads : {"1", "2", "4"}) {
            const std::string name = std::string("t") + threads + ".exr";
            ChildOptions opt;
            opt.cwd = d.path();
            // dwaa is lossy: bake refuses it without --allow-lossy (the flag changes nothing
            // else, and the lossy output must be as independent of the thread count).
            Child c = run({"bake", "in.png", "-o", "out.exr", "--compression", comp, "--threads",
                           threads, "--preview", "--allow-lossy"},
                          opt);
            ASSERT_EQ(c.status, 0) << c.err;
            ASSERT_EQ(::rename((d / "out.exr").c_str(), (d / name).c_str()), 0);
            files.push_back(d / name);
        }
        SCOPED_TRACE(comp);
        expect_same_exr_except_command_line(files[0], files[1]);
        expect_same_exr_except_command_line(files[0], files[2]);
        std::string t1 = read_file(files[0]), t2 = read_file(files[1]);
        size_t at = t1.find("--threads 1");
        ASSERT_NE(at, std::string::npos) << "spectex:commandLine does not hold the arguments";
        t1.replace(at, 11, "--threads 2");
        EXPECT_TRUE(t1 == t2) << "--threads 1 and --threads 2 differ beyond spectex:commandLine ("
                              << comp << ")";
    }
}
