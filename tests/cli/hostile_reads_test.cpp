// Hostile reads: every file spectex reads, named on the command line or referenced by another
// file, given as something that is not a plain image or table: device files (/dev/zero,
// /dev/urandom), FIFOs with no writer, folders, lists of binary garbage, images whose channels are
// not colours, and truncated images of every format.
//
//   Conventions (as in hard_inputs_test.cpp): a failure exits 1 (2 for usage errors) at once, in
//   bounded memory, with "spectex: <file>: <cause>" as the first line of stderr (a failed file in a
//   batch is followed by the batch's summary line), and leaves no output and no temporary file.
//   An observer or light table (--observer, --illuminant) is a setting every command checks before
//   any input: a usage error, exit 2, "spectex <command>: <option>: <file>: <cause>" then the
//   "Try 'spectex <command> --help'." line.
//
// Every run goes through run_limited(): a child with a 2 GiB address-space limit (so that a
// regression allocating without bound fails fast instead of taking the machine's memory), killed
// after kTimeout seconds and reported as "hung".
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <climits>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "cli/cli_util.h"
#include "cli/exr_read.h"

using namespace spectex_test;

namespace {

// An AddressSanitizer binary cannot run under RLIMIT_AS (its shadow): the same 2 GiB bound is
// set through ASAN_OPTIONS then (allocations over it fail as they would under the limit; a
// resident size over it is an error).
const bool kSanitized = kBinarySanitized;

// The environment of a limited run: this process's, plus `extra`, plus the memory bound for ASan.
std::vector<std::string> limited_environment(const std::vector<std::string>& extra) {
    std::vector<std::string> env = environment_with(extra);
    if (!kSanitized) return env;
    const std::string bound =
        "hard_rss_limit_mb=2048:max_allocation_size_mb=2048:allocator_may_return_null=1";
    bool found = false;
    for (auto& e : env)
        if (e.rfind("ASAN_OPTIONS=", 0) == 0) {
            e += (e.size() > 13 ? ":" : "") + bound;
            found = true;
            break;  // getenv reads the first entry
        }
    if (!found) env.push_back("ASAN_OPTIONS=" + bound);
    return env;
}

// Seconds: a hostile read must fail within kFailFast, and is killed as hung after kTimeout. Under
// AddressSanitizer (-O1, instrumented, tests/sanitize/run.sh) the same reads run 3-5x slower: the
// bounds are scaled, not dropped (a read of a truncated 4 MB EXR took 11-14 s there on a loaded
// 2-core machine).
const double kSanitizerScale = kBinarySanitized ? 4.0 : 1.0;
const double kFailFast = 10.0 * kSanitizerScale;
const double kTimeout = 20.0 * kSanitizerScale;

bool contains(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

void write_bytes(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

struct Limited {
    int status = -1;  // exit status, 128+signal when killed by one
    bool hung = false;
    double seconds = 0;
    long maxrss_kb = 0;
    std::string out, err;
    std::string first_line() const { return err.substr(0, err.find('\n')); }
};

// Runs spectex with args; extra_env "NAME=value" entries; stdin from `stdin_path` (default
// /dev/null). Kills it after kTimeout seconds.
Limited run_limited(const std::vector<std::string>& args,
                    const std::vector<std::string>& extra_env = {},
                    const std::string& stdin_path = "/dev/null") {
    ScratchDir io;
    const std::string out = io / "out", err = io / "err";
    std::vector<std::string> argv_s = spectex_argv(args), env_s = limited_environment(extra_env);
    std::vector<char*> argv = c_array(argv_s), envp = c_array(env_s);
    Limited r;
    const auto t0 = std::chrono::steady_clock::now();
    pid_t pid = fork();
    if (pid == 0) {
        // Async-signal-safe calls only (the parent may have threads).
        int fi = ::open(stdin_path.c_str(), O_RDONLY);
        int fo = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
        int fe = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
        if (fi < 0 || fo < 0 || fe < 0) _exit(125);
        dup2(fi, 0);
        dup2(fo, 1);
        dup2(fe, 2);
        if (!kSanitized) {
            struct rlimit as {};
            as.rlim_cur = as.rlim_max = rlim_t{2} << 30;
            setrlimit(RLIMIT_AS, &as);
        }
        execve(argv[0], argv.data(), envp.data());
        _exit(127);
    }
    if (pid < 0) return r;
    int st = 0;
    struct rusage ru {};
    for (;;) {
        pid_t w = wait4(pid, &st, WNOHANG, &ru);
        if (w == pid) break;
        if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() >
            kTimeout) {
            kill(pid, SIGKILL);
            wait4(pid, &st, 0, &ru);
            r.hung = true;
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    r.maxrss_kb = ru.ru_maxrss;
    r.out = read_file(out);
    r.err = read_file(err);
    return r;
}

// The checks after a hostile read: not hung, exit `status`, first line "spectex: <file>: ...",
// at most the batch summary after it, no output, no temporary file. With `option` (a setting of
// `command`, e.g. "basis" and "--observer"): the usage-error form, exit 2, first line
// "spectex <command>: <option>: <file>: ..." and then only the Try line.
void expect_refused(const std::string& what, const Limited& r, const std::string& file,
                    const std::string& output, const std::string& cause = "", int status = 1,
                    const std::string& command = "", const std::string& option = "") {
    SCOPED_TRACE(what);
    ASSERT_FALSE(r.hung) << "hung: killed after " << kTimeout << " s";
    EXPECT_EQ(r.status, status) << r.err;
    const std::string lead =
        option.empty() ? "spectex: " : "spectex " + command + ": " + option + ": ";
    EXPECT_EQ(r.first_line().rfind(lead + file + ": ", 0), 0u)
        << "stderr does not start with '" << lead << file << ": ':\n"
        << r.err;
    if (!cause.empty())
        EXPECT_TRUE(contains(r.first_line(), cause)) << "no '" << cause << "' in:\n" << r.err;
    // One line, then perhaps the batch summary ("spectex: 0 baked, ... failed of 1 ...") and, after
    // a failed run, the command to rerun ("spectex: the command was: ..."): nothing else.
    std::string rest = r.err.substr(std::min(r.err.size(), r.err.find('\n') + 1));
    auto drop_line = [&rest](const std::string& prefix) {
        if (rest.rfind(prefix, 0) == 0)
            rest = rest.substr(std::min(rest.size(), rest.find('\n') + 1));
    };
    drop_line("spectex: 0 baked");
    if (!option.empty()) drop_line("Try 'spectex " + command + " --help'.");
    if (r.status == 1) {
        EXPECT_EQ(rest.rfind("spectex: the command was: ", 0), 0u)
            << "a failed run ends with its command:\n"
            << r.err;
        drop_line("spectex: the command was: ");
    }
    EXPECT_TRUE(rest.empty()) << "more than one message line:\n" << r.err;
    EXPECT_LT(r.seconds, kFailFast);
    if (!output.empty()) {
        struct stat st;
        EXPECT_NE(::lstat(output.c_str(), &st), 0) << output << " exists after a failure";
        auto tmp = temp_files_in(dir_of(output));
        EXPECT_TRUE(tmp.empty()) << "temporary file left: " << (tmp.empty() ? "" : tmp.front());
    }
    std::printf("  %-58s exit %d, %.2f s, %ld kB: %s\n", what.c_str(), r.status, r.seconds,
                r.maxrss_kb, r.first_line().c_str());
}

void write_rgb_exr(const std::string& path, int w = 8, int h = 6) {
    std::vector<float> px(static_cast<size_t>(w * h * 3));
    for (size_t i = 0; i < px.size(); ++i)
        px[i] = 0.05f + 0.9f * static_cast<float>((i * 37) % 101) / 100.0f;
    write_image(path, w, h, 3, OIIO::TypeDesc::FLOAT, px.data());
}

// An OpenEXR with exactly these channels (half), values in (0, 1), `alpha` an exception: the
// channel named so gets 0.5 everywhere. Written with OpenEXR directly: no reordering, no defaults.
void write_named_exr(const std::string& path, const std::vector<std::string>& names, int w = 8,
                     int h = 6, const std::vector<std::vector<float>>* values = nullptr) {
    Imf::Header hdr(w, h);
    for (const auto& n : names) hdr.channels().insert(n.c_str(), Imf::Channel(Imf::FLOAT));
    std::vector<std::vector<float>> planes(names.size(),
                                           std::vector<float>(static_cast<size_t>(w * h)));
    Imf::FrameBuffer fb;
    for (size_t c = 0; c < names.size(); ++c) {
        for (size_t i = 0; i < planes[c].size(); ++i)
            planes[c][i] = values ? (*values)[c][i]
                                  : 0.1f + 0.8f * static_cast<float>((i * 7 + c * 13) % 17) / 17.0f;
        fb.insert(names[c].c_str(),
                  Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(planes[c].data()), sizeof(float),
                             sizeof(float) * static_cast<size_t>(w)));
    }
    Imf::OutputFile f(path.c_str(), hdr);
    f.setFrameBuffer(fb);
    f.writePixels(h);
}

std::string mkfifo_in(const ScratchDir& d, const std::string& name) {
    const std::string p = d / name;
    if (::mkfifo(p.c_str(), 0644) != 0)
        throw std::runtime_error("mkfifo " + p + ": " + std::strerror(errno));
    return p;
}

// A small OCIO v2 config whose colour space "lut_space" reads `lut` through a FileTransform.
std::string lut_config(const ScratchDir& d, const std::string& lut,
                       const std::string& name = "c.ocio") {
    const std::string p = d / name;
    write_bytes(p, lut_config_text(".", lut));
    return p;
}

// The places a file is named, as (args before the file, the option) for bake and basis.
struct Slot {
    const char* name;
    std::vector<std::string> (*args)(const std::string& file, const ScratchDir& d);
    bool env = false;  // the file goes in $OCIO
};

std::vector<Slot> slots() {
    return {
        {"bake --config",
         [](const std::string& f, const ScratchDir& d) {
             write_rgb_exr(d / "in.exr");
             return std::vector<std::string>{"bake",        d / "in.exr", "-o",
                                             d / "out.exr", "--config",   f};
         }},
        {"bake with OCIO=",
         [](const std::string&, const ScratchDir& d) {
             write_rgb_exr(d / "in.exr");
             return std::vector<std::string>{"bake", d / "in.exr", "-o", d / "out.exr"};
         },
         true},
        {"bake --from-list",
         [](const std::string& f, const ScratchDir& d) {
             return std::vector<std::string>{"bake", "-o", d / "out.exr", "--from-list", f};
         }},
        {"bake --wavelengths-file",
         [](const std::string& f, const ScratchDir& d) {
             write_rgb_exr(d / "in.exr");
             return std::vector<std::string>{"bake",        d / "in.exr",         "-o",
                                             d / "out.exr", "--wavelengths-file", f};
         }},
        {"bake --basis",
         [](const std::string& f, const ScratchDir& d) {
             write_rgb_exr(d / "in.exr");
             return std::vector<std::string>{"bake",        d / "in.exr", "-o",
                                             d / "out.exr", "--basis",    f};
         }},
        {"bake --observer",
         [](const std::string& f, const ScratchDir& d) {
             write_rgb_exr(d / "in.exr");
             return std::vector<std::string>{"bake",        d / "in.exr", "-o",
                                             d / "out.exr", "--observer", f};
         }},
        {"bake --illuminant",
         [](const std::string& f, const ScratchDir& d) {
             write_rgb_exr(d / "in.exr");
             return std::vector<std::string>{"bake",        d / "in.exr",   "-o",
                                             d / "out.exr", "--illuminant", f};
         }},
        {"bake INPUT",
         [](const std::string& f, const ScratchDir& d) {
             return std::vector<std::string>{"bake", f, "-o", d / "out.exr"};
         }},
        {"verify --source",
         [](const std::string& f, const ScratchDir& d) {
             write_rgb_exr(d / "in.exr");
             run_spectex({"bake", d / "in.exr", "-o", d / "baked.exr"});
             return std::vector<std::string>{"verify", d / "baked.exr", "--source", f};
         }},
        {"verify EXR",
         [](const std::string& f, const ScratchDir&) {
             return std::vector<std::string>{"verify", f};
         }},
        {"info EXR",
         [](const std::string& f, const ScratchDir&) {
             return std::vector<std::string>{"info", f};
         }},
        {"basis --observer",
         [](const std::string& f, const ScratchDir& d) {
             return std::vector<std::string>{"basis", "-o", d / "basis.csv", "--observer", f};
         }},
        {"basis --illuminant",
         [](const std::string& f, const ScratchDir& d) {
             return std::vector<std::string>{"basis", "-o", d / "basis.csv", "--illuminant", f};
         }},
        {"basis --wavelengths-file",
         [](const std::string& f, const ScratchDir& d) {
             return std::vector<std::string>{"basis", "-o", d / "basis.csv", "--wavelengths-file",
                                             f};
         }},
    };
}

void refuse_in_every_slot(const std::string& label,
                          const std::function<std::string(const ScratchDir&)>& make,
                          const std::string& cause) {
    for (const auto& s : slots()) {
        ScratchDir d;
        const std::string file = make(d);
        auto args = s.args(file, d);
        Limited r = run_limited(
            args, s.env ? std::vector<std::string>{"OCIO=" + file} : std::vector<std::string>{});
        const std::string out =
            std::string(s.name).rfind("basis", 0) == 0 ? d / "basis.csv" : d / "out.exr";
        // bake's settings the same for every file (config, grid, tables) are checked once, before
        // any input: a usage error, exit 2; an input, a list, a source or an EXR is work: exit 1.
        // Observer and light tables are settings of every command (bake and basis here), refused
        // in the usage-error form that names the option as well as the file.
        const std::string n = s.name;
        const std::string command = n.substr(0, n.find(' ')), option = n.substr(n.find(' ') + 1);
        const bool table = option == "--observer" || option == "--illuminant";
        const bool setting =
            table || (command == "bake" && n != "bake INPUT" && n != "bake --from-list");
        expect_refused(n + " " + label, r, file, out, cause, setting ? 2 : 1, command,
                       table ? option : "");
    }
}

}  // namespace

// =============================================================================================
// 1. An OpenEXR whose only channel is A: no colour to bake (it used to crash with SIGSEGV).

TEST(HostileReads, AlphaOnlyExrIsRefused) {
    ScratchDir d;
    const std::string in = d / "alpha.exr";
    write_named_exr(in, {"A"});
    for (const auto& extra : std::vector<std::vector<std::string>>{{}, {"--tile", "16"}}) {
        std::vector<std::string> args{"bake", in, "-o", d / "out.exr"};
        args.insert(args.end(), extra.begin(), extra.end());
        expect_refused(extra.empty() ? "bake A-only" : "bake --tile A-only", run_limited(args), in,
                       d / "out.exr", "no colour channels");
    }
    // verify --source reads its source the same way.
    const std::string rgb = d / "rgb.exr", baked = d / "baked.exr";
    write_rgb_exr(rgb);
    ASSERT_EQ(run_spectex({"bake", rgb, "-o", baked}).status, 0);
    Limited r = run_limited({"verify", baked, "--source", in});
    expect_refused("verify --source A-only", r, in, "", "no colour channels");
    EXPECT_TRUE(contains(r.first_line(), "the file has A")) << r.err;
}

// =============================================================================================
// 2. Files that are not regular files, wherever a file is named.

TEST(HostileReads, DevZeroIsRefusedEverywhere) {
    refuse_in_every_slot(
        "/dev/zero", [](const ScratchDir&) { return std::string("/dev/zero"); },
        "character device");
}

TEST(HostileReads, DevUrandomIsRefusedEverywhere) {
    refuse_in_every_slot(
        "/dev/urandom", [](const ScratchDir&) { return std::string("/dev/urandom"); },
        "character device");
}

TEST(HostileReads, FifoWithoutWriterDoesNotBlock) {
    refuse_in_every_slot(
        "FIFO", [](const ScratchDir& d) { return mkfifo_in(d, "pipe.csv"); }, "FIFO");
}

TEST(HostileReads, FolderIsRefusedEverywhere) {
    refuse_in_every_slot(
        "folder",
        [](const ScratchDir& d) {
            ::mkdir((d / "folder.csv").c_str(), 0755);
            return d / "folder.csv";
        },
        "directory");
}

TEST(HostileReads, OcioLutFileMustBeRegular) {
    // A FileTransform src on a device or a FIFO, absolute or found through the search path.
    struct Case {
        const char* name;
        std::function<std::string(const ScratchDir&)> lut;  // returns the src written in the config
        std::string resolved;                               // "" = d / src
    };
    const std::vector<Case> cases = {
        {"LUT /dev/zero", [](const ScratchDir&) { return std::string("/dev/zero"); }, "/dev/zero"},
        {"LUT /dev/urandom", [](const ScratchDir&) { return std::string("/dev/urandom"); },
         "/dev/urandom"},
        {"LUT FIFO (search path)",
         [](const ScratchDir& d) {
             mkfifo_in(d, "lut.cube");
             return std::string("lut.cube");
         },
         ""},
        {"LUT folder",
         [](const ScratchDir& d) {
             ::mkdir((d / "lut.cube").c_str(), 0755);
             return std::string("lut.cube");
         },
         ""},
    };
    for (const auto& c : cases) {
        ScratchDir d;
        const std::string src = c.lut(d);
        const std::string cfg = lut_config(d, src);
        const std::string lut = c.resolved.empty() ? d / src : c.resolved;
        write_rgb_exr(d / "in.exr");
        Limited r = run_limited({"bake", d / "in.exr", "-o", d / "out.exr", "--config", cfg,
                                 "--colorspace", "lut_space"});
        expect_refused(std::string(c.name) + " via --config", r, lut, d / "out.exr", "LUT file", 2);
        // The same config through $OCIO, run from another folder: the search path is the config's.
        r = run_limited({"bake", d / "in.exr", "-o", d / "out.exr", "--colorspace", "lut_space"},
                        {"OCIO=" + cfg});
        expect_refused(std::string(c.name) + " via OCIO=", r, lut, d / "out.exr", "LUT file", 2);
    }
    // Control: the same config with a real LUT bakes (relative src resolved from the config's
    // folder).
    ScratchDir d;
    write_bytes(d / "lut.cube", "LUT_1D_SIZE 2\n0 0 0\n1 1 1\n");
    write_rgb_exr(d / "in.exr");
    RunResult ok = run_spectex({"bake", d / "in.exr", "-o", d / "out.exr", "--config",
                                lut_config(d, "lut.cube"), "--colorspace", "lut_space"});
    EXPECT_EQ(ok.status, 0) << ok.err;
}

TEST(HostileReads, OversizedFilesAreRefusedBeforeReading) {
    // Sparse files just over each limit: refused from their size, without reading them.
    struct Case {
        const char* name;
        off_t size;
        std::vector<std::string> (*args)(const std::string&, const ScratchDir&);
    };
    const std::vector<Case> cases = {
        {"config over 64 MiB", (off_t{64} << 20) + 1,
         [](const std::string& f, const ScratchDir& d) {
             write_rgb_exr(d / "in.exr");
             return std::vector<std::string>{"bake",        d / "in.exr", "-o",
                                             d / "out.exr", "--config",   f};
         }},
        {"wavelength file over 16 MiB", (off_t{16} << 20) + 1,
         [](const std::string& f, const ScratchDir& d) {
             write_rgb_exr(d / "in.exr");
             return std::vector<std::string>{"bake",        d / "in.exr",         "-o",
                                             d / "out.exr", "--wavelengths-file", f};
         }},
        {"input list over 256 MiB", (off_t{256} << 20) + 1,
         [](const std::string& f, const ScratchDir& d) {
             return std::vector<std::string>{"bake", "-o", d / "out.exr", "--from-list", f};
         }},
    };
    for (const auto& c : cases) {
        ScratchDir d;
        const std::string f = d / "big.txt";
        int fd = ::open(f.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        ASSERT_GE(fd, 0);
        ASSERT_EQ(::ftruncate(fd, c.size), 0);
        ::close(fd);
        Limited r = run_limited(c.args(f, d));
        expect_refused(c.name, r, f, d / "out.exr", "limit",
                       std::string(c.name).rfind("input list", 0) == 0 ? 1 : 2);
        EXPECT_LT(r.seconds, 5.0);
    }
}

// =============================================================================================
// 2b. Input lists: binary data, absurd lines, nothing listed.

TEST(HostileReads, InputListContentIsChecked) {
    struct Case {
        const char* name;
        std::string bytes;
        std::string cause;
    };
    const std::vector<Case> cases = {
        {"NUL on line 3", std::string("a.png\nb.png\nc\0d.png\n", 16), "line 3: NUL byte"},
        {"control byte on line 2", "a.png\n\x01\x02\x03garbage\n",
         "line 2: control character 0x01"},
        {"random bytes",
         [] {
             std::mt19937 rng(7);
             std::string s(4096, '\0');
             for (auto& c : s) c = static_cast<char>(rng() & 0xff);
             s[0] = 'x';
             s[1] = '\x02';
             return s;
         }(),
         "line 1: control character"},
        {"line longer than PATH_MAX", "a.png\n" + std::string(PATH_MAX + 10, 'x') + "\n",
         "line 2: longer than PATH_MAX"},
        {"empty list", "", "names no files"},
        {"comments only", "# nothing\n\n# here\n", "names no files"},
    };
    for (const auto& c : cases) {
        ScratchDir d;
        const std::string list = d / "list.txt";
        write_bytes(list, c.bytes);
        Limited r = run_limited({"bake", "-o", d / "out.exr", "--from-list", list});
        expect_refused(std::string("--from-list ") + c.name, r, list, d / "out.exr", c.cause);
    }
    // Standard input: /dev/zero and /dev/urandom as stdin fail at their first bad byte, not after
    // reading until memory runs out (expect_refused bounds the time). /dev/zero's is on line 1;
    // random bytes may hold a newline before their first control byte (about 1 run in 30), so
    // theirs is on some early line.
    for (const char* dev : {"/dev/zero", "/dev/urandom"}) {
        ScratchDir d;
        Limited r = run_limited({"bake", "-o", d / "out.exr", "--from-list", "-"}, {}, dev);
        expect_refused(std::string("--from-list - < ") + dev, r, "standard input (--from-list -)",
                       d / "out.exr",
                       std::string(dev) == "/dev/zero" ? "line 1: NUL byte" : "binary data");
    }
    // Control: a list on stdin still works, with CRLF line ends.
    ScratchDir d;
    write_rgb_exr(d / "in.exr");
    write_bytes(d / "list.txt", "# inputs\r\n" + (d / "in.exr") + "\r\n");
    Limited ok = run_limited({"bake", "-o", d / "out.exr", "--from-list", "-"}, {}, d / "list.txt");
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_TRUE(file_exists(d / "out.exr"));
}

// =============================================================================================
// 3. Channels are chosen by name in OpenEXR: spectral, polarised, depth and other data channels
//    are never colour or alpha.

TEST(HostileReads, ExrWithoutColourChannelsIsRefusedWithItsChannels) {
    struct Case {
        const char* name;
        std::vector<std::string> channels;
        std::vector<std::string> must_contain;
    };
    std::vector<std::string> spectral, polarised, thousand;
    for (int l = 380; l <= 780; l += 5) spectral.push_back("T." + std::to_string(l) + "nm");
    spectral.push_back("A");
    for (const char* s : {"S0", "S1", "S2", "S3"})
        for (int l = 400; l <= 700; l += 100)
            polarised.push_back(std::string(s) + "." + std::to_string(l) + "nm");
    for (int i = 0; i < 1000; ++i) thousand.push_back("c" + std::to_string(1000 + i));
    const std::vector<Case> cases = {
        {"spectral T.*nm + A", spectral, {"T.380nm", "channels)"}},
        {"polarised S0-S3", polarised, {"S0.400nm"}},
        {"1000 data channels", thousand, {"c1000", "1000 channels"}},
        {"R, G only", {"R", "G"}, {"the file has R, G"}},
        {"Z only", {"Z"}, {"the file has Z"}},
    };
    for (const auto& c : cases) {
        ScratchDir d;
        const std::string in = d / "in.exr";
        write_named_exr(in, c.channels, 4, 3);
        Limited r = run_limited({"bake", in, "-o", d / "out.exr"});
        expect_refused(std::string("channels: ") + c.name, r, in, d / "out.exr",
                       "no colour channels");
        for (const auto& s : c.must_contain)
            EXPECT_TRUE(contains(r.first_line(), s)) << c.name << ": " << r.err;
        EXPECT_LT(r.first_line().size(), 400u)
            << "the channel list is not truncated: " << r.first_line().size();
    }
}

TEST(HostileReads, DepthIsNeverAlpha) {
    // R, G, B, Z: the same spectra as R, G, B alone, and no alpha in the output.
    ScratchDir d;
    const int w = 6, h = 4;
    std::vector<std::vector<float>> rgbz(4, std::vector<float>(w * h));
    for (int i = 0; i < w * h; ++i) {
        rgbz[0][i] = 0.1f + 0.03f * i;
        rgbz[1][i] = 0.6f - 0.02f * i;
        rgbz[2][i] = 0.3f;
        rgbz[3][i] = 100.0f + i;  // depth: far away
    }
    write_named_exr(d / "rgbz.exr", {"R", "G", "B", "Z"}, w, h, &rgbz);
    std::vector<std::vector<float>> rgb(rgbz.begin(), rgbz.begin() + 3);
    write_named_exr(d / "rgb.exr", {"R", "G", "B"}, w, h, &rgb);
    RunResult a = run_spectex({"bake", d / "rgbz.exr", "-o", d / "a.exr"});
    RunResult b = run_spectex({"bake", d / "rgb.exr", "-o", d / "b.exr"});
    ASSERT_EQ(a.status, 0) << a.err;
    ASSERT_EQ(b.status, 0) << b.err;
    ExrImage ia = read_exr(d / "a.exr"), ib = read_exr(d / "b.exr");
    EXPECT_FALSE(ia.has("A")) << "Z was taken as alpha";
    for (const auto& [l, name] : spectral_channels(ib)) {
        ASSERT_TRUE(ia.has(name));
        EXPECT_EQ(ia.pixels.at(name), ib.pixels.at(name)) << name;
    }
    // verify --source on the R, G, B, Z source compares the same colours.
    RunResult v = run_spectex({"verify", d / "a.exr", "--source", d / "rgbz.exr"});
    EXPECT_EQ(v.status, 0) << v.err << v.out;
}

TEST(HostileReads, LayersAndGreyAreChosenByName) {
    ScratchDir d;
    // No plain R, G, B: the first layer (by name) with .R/.G/.B, its own alpha, and a note.
    write_named_exr(d / "layers.exr", {"specular.R", "specular.G", "specular.B", "diffuse.R",
                                       "diffuse.G", "diffuse.B", "diffuse.A", "Z", "T.500nm"});
    RunResult r = run_spectex({"bake", d / "layers.exr", "-o", d / "layers_out.exr"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(contains(r.err, "layer 'diffuse'")) << r.err;
    EXPECT_TRUE(read_exr(d / "layers_out.exr").has("A"));
    // Grey: Y with alpha; "alpha" in any case is alpha, data channels are not.
    write_named_exr(d / "grey.exr", {"Y", "Alpha", "Z"});
    r = run_spectex({"bake", d / "grey.exr", "-o", d / "grey_out.exr"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(read_exr(d / "grey_out.exr").has("A"));
    write_named_exr(d / "greyz.exr", {"Y", "Z"});
    r = run_spectex({"bake", d / "greyz.exr", "-o", d / "greyz_out.exr"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(read_exr(d / "greyz_out.exr").has("A"));
}

// =============================================================================================
// 4. Truncated images of every format fail, at every cut point.

TEST(HostileReads, TruncatedImagesOfEveryFormatFail) {
    struct Format {
        const char* name;
        const char* ext;
        OIIO::TypeDesc type;
        std::vector<std::pair<std::string, std::string>> attrs;
        int tile;
        std::vector<double> cuts;  // fractions of the file kept; < 0: all but that many bytes
    };
    // Under the sanitizers (each bake about 8 times slower) a cut near the start, one in the middle
    // and one byte short of the end of every format: the three kinds of damage; the whole suite
    // cuts at seven places.
    const std::vector<double> all = kBinarySanitized
                                        ? std::vector<double>{0.05, 0.5, -1}
                                        : std::vector<double>{0.05, 0.25, 0.5, 0.75, 0.9, 0.99, -1};
    // TGA: a cut in the TGA 2.0 footer leaves a valid TGA 1.0 file with every pixel: only cuts in
    // the pixel data can be told apart (see the report).
    const std::vector<Format> formats = {
        {"PNG", "png", OIIO::TypeDesc::UINT8, {}, 0, all},
        {"JPEG baseline", "jpg", OIIO::TypeDesc::UINT8, {}, 0, all},
        {"JPEG progressive", "jpg", OIIO::TypeDesc::UINT8, {{"jpeg:progressive", "1"}}, 0, all},
        {"TIFF", "tif", OIIO::TypeDesc::UINT8, {}, 0, all},
        {"TIFF tiled", "tif", OIIO::TypeDesc::UINT16, {}, 16, all},
        {"OpenEXR", "exr", OIIO::TypeDesc::HALF, {}, 0, all},
        {"OpenEXR tiled", "exr", OIIO::TypeDesc::HALF, {}, 16, all},
        {"Radiance HDR", "hdr", OIIO::TypeDesc::FLOAT, {}, 0, all},
        {"TGA",
         "tga",
         OIIO::TypeDesc::UINT8,
         {},
         0,
         kBinarySanitized ? std::vector<double>{0.05, 0.5}
                          : std::vector<double>{0.05, 0.25, 0.5, 0.75, 0.9}},
        {"BMP", "bmp", OIIO::TypeDesc::UINT8, {}, 0, all},
    };
    const int w = 64, h = 64;
    std::mt19937 rng(11);
    std::vector<float> px(static_cast<size_t>(w * h * 3));
    for (auto& v : px) v = static_cast<float>(rng() % 256) / 255.0f;
    for (const auto& f : formats) {
        ScratchDir d;
        const std::string full = d / (std::string("full.") + f.ext);
        OIIO::ImageSpec spec(w, h, 3, f.type);
        for (const auto& [k, v] : f.attrs) spec.attribute(k, std::atoi(v.c_str()));
        if (f.tile) spec.tile_width = spec.tile_height = f.tile;
        auto o = OIIO::ImageOutput::create(full);
        ASSERT_TRUE(o && o->open(full, spec) && o->write_image(OIIO::TypeDesc::FLOAT, px.data()) &&
                    o->close())
            << f.name;
        // Control: the whole file bakes.
        RunResult ok = run_spectex({"bake", full, "-o", d / "whole_baked.exr"});
        ASSERT_EQ(ok.status, 0) << f.name << ": " << ok.err;
        const std::string bytes = read_file(full);
        for (double k : f.cuts) {
            const size_t keep = k < 0 ? bytes.size() - static_cast<size_t>(-k)
                                      : static_cast<size_t>(static_cast<double>(bytes.size()) * k);
            const std::string cut = d / (std::string("cut.") + f.ext), out = d / "cut_baked.exr";
            write_bytes(cut, bytes.substr(0, keep));
            Limited r = run_limited({"bake", cut, "-o", out});
            expect_refused(std::string(f.name) + " cut at " + std::to_string(keep) + "/" +
                               std::to_string(bytes.size()),
                           r, cut, out);
        }
    }
}

TEST(HostileReads, TruncatedTiledAndScanlineFilesFailVerifyAndInfo) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 256, 128);
    for (const char* mode : {"--mipmap", "--type"}) {
        const std::string exr = d / "m.exr", cut = d / "cut.exr";
        std::vector<std::string> args = {"bake", png, "-o", exr, "-q", mode};
        if (std::string(mode) == "--type") args.push_back("float");
        ASSERT_EQ(run_spectex(args).status, 0);
        const std::string bytes = read_file(exr);
        std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - bytes.size() / 10);
        RunResult v = run_spectex({"verify", cut});
        EXPECT_EQ(v.status, 1) << mode << ": " << v.out;
        EXPECT_TRUE(has_text(v.err, "incomplete")) << v.err;
        RunResult i = run_spectex({"info", cut});
        EXPECT_EQ(i.status, 1) << mode;
        EXPECT_EQ(run_spectex({"verify", exr}).status, 0);
    }
}

// A large file that is no image of the format its name says: one reader says no at once. OIIO's
// own open tried every reader, some of which read the whole file (57 s for 200 MB). The bound
// below is a guard against that hang coming back, far above the time it takes (under a second).
TEST(HostileReads, AFileOfZerosNamedPngFailsAtOnce) {
    ScratchDir d;
    {
        std::ofstream z(d / "z.png", std::ios::binary);
        const std::string block(1 << 20, '\0');
        for (int i = 0; i < 64; ++i) z << block;
    }
    const auto t0 = std::chrono::steady_clock::now();
    RunResult r = run_spectex({"bake", d / "z.png", "-o", d / "z.exr"});
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(r.status, 1);
    EXPECT_TRUE(has_text(r.err, "Not a PNG file")) << r.err;
    EXPECT_LT(s, 15.0);
    // A PNG named .jpg is read by its contents.
    const std::string png = pattern_png(d, "in.png", 16, 8);
    ASSERT_EQ(std::rename(png.c_str(), (d / "really_png.jpg").c_str()), 0);
    EXPECT_EQ(run_spectex({"bake", d / "really_png.jpg", "-o", d / "j.exr", "-q"}).status, 0);
}

// Luminance/chroma EXRs (Y, RY, BY) were baked as grey from Y alone: the colour was dropped.
TEST(HostileReads, LuminanceChromaIsRefusedNotBakedGrey) {
    ScratchDir d;
    const std::string in = d / "yc.exr";
    std::vector<float> px(8 * 8 * 3, 0.25f);
    write_image(in, 8, 8, 3, OIIO::TypeDesc::FLOAT, px.data(), {}, 0);
    // Rename the channels to Y, RY, BY.
    ExrImage img = read_exr(in);
    Imf::Header h(img.header.displayWindow(), img.header.dataWindow());
    for (const char* n : {"Y", "RY", "BY"}) h.channels().insert(n, Imf::Channel(Imf::FLOAT));
    {
        Imf::OutputFile out(in.c_str(), h);
        Imf::FrameBuffer fb;
        const char* src[3] = {"R", "G", "B"};
        const char* dst[3] = {"Y", "RY", "BY"};
        for (int c = 0; c < 3; ++c)
            fb.insert(dst[c],
                      Imf::Slice::Make(Imf::FLOAT, img.pixels[src[c]].data(), img.data_window));
        out.setFrameBuffer(fb);
        out.writePixels(img.height);
    }
    RunResult r = run_spectex({"bake", in, "-o", d / "o.exr"});
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(has_text(r.err, "luminance/chroma channels (Y, RY, BY) are not supported"))
        << r.err;
    EXPECT_FALSE(file_exists(d / "o.exr"));
}

// Header limits are named for what they are: an attribute past the header cap is reported with
// the cap, not as larger than the file; an int whose size field is wrong says so.
TEST(HostileReads, HeaderSizesAreReportedForWhatTheyAre) {
    ScratchDir d;
    auto le32 = [](int32_t v) {
        std::string s(4, '\0');
        for (int i = 0; i < 4; ++i)
            s[i] = static_cast<char>((static_cast<uint32_t>(v) >> (8 * i)) & 0xff);
        return s;
    };
    const std::string magic = le32(20000630) + le32(2);
    auto attr = [&](const std::string& name, const std::string& type, int32_t size,
                    const std::string& value) {
        return name + std::string(1, '\0') + type + std::string(1, '\0') + le32(size) + value;
    };
    // A 70 MB attribute: past the header cap, whatever the file's size.
    write_bytes(d / "huge.exr", magic + attr("note", "string", 70 << 20, std::string(64, 'x')));
    RunResult h = run_spectex({"info", d / "huge.exr"});
    EXPECT_EQ(h.status, 1) << h.err;
    EXPECT_TRUE(has_text(h.err, "64 MiB")) << h.err;
    EXPECT_FALSE(has_text(h.err, "larger than the file")) << h.err;
    // An int whose size field says 2.
    write_bytes(d / "int2.exr", magic + attr("count", "int", 2, std::string(2, '\0')) +
                                    attr("dataWindow", "box2i", 16, std::string(16, '\0')) +
                                    std::string(1, '\0') + std::string(64, '\0'));
    RunResult i = run_spectex({"info", d / "int2.exr"});
    EXPECT_EQ(i.status, 1) << i.err;
    EXPECT_TRUE(has_text(i.err, "'count' of type int is 2 bytes, not 4")) << i.err;
    EXPECT_FALSE(has_text(i.err, "chunks")) << i.err;
}

// A tiled TIFF's header claims what its tiles do not hold: a 64x64 file whose width and length
// tags say 16000 (a few hundred bytes). Tiled inputs were read whole, so 4 GB were allocated and
// zeroed before the first missing tile was found (10 s; std::bad_alloc under a 2 GiB limit): they
// are read a band of tile rows at a time, and such a file fails at once, naming the file and
// the reader's reason, in the memory of a band.
TEST(HostileReads, ATiledTiffClaimingHugeSizeFailsInABandsMemory) {
    ScratchDir d;
    std::vector<uint8_t> px(64 * 64 * 4, 200);
    const std::string tif = d / "claims.tif";
    write_image(tif, 64, 64, 4, OIIO::TypeDesc::UINT8, px.data(), {}, 64);
    std::string b = read_file(tif);
    ASSERT_EQ(b.substr(0, 4), std::string("II*\0", 4));
    auto u16 = [&](size_t at) {
        return static_cast<uint32_t>(static_cast<uint8_t>(b[at])) |
               static_cast<uint32_t>(static_cast<uint8_t>(b[at + 1])) << 8;
    };
    const size_t ifd = u16(4) | static_cast<size_t>(u16(6)) << 16;
    int patched = 0;
    for (uint32_t k = 0, n = u16(ifd); k < n; ++k) {
        const size_t e = ifd + 2 + 12 * k;
        const uint32_t tag = u16(e), type = u16(e + 2);
        if (tag != 256 && tag != 257) continue;  // ImageWidth, ImageLength
        const uint32_t v = 16000;
        for (size_t i = 0; i < (type == 3 ? 2u : 4u); ++i)
            b[e + 8 + i] = static_cast<char>((v >> (8 * i)) & 0xff);
        ++patched;
    }
    ASSERT_EQ(patched, 2);
    write_bytes(tif, b);
    const std::string out = d / "out.exr";
    const Limited r = run_limited({"bake", tif, "-o", out});
    expect_refused("tiled TIFF claiming 16000x16000", r, tif, out, "read failed");
    if (!kSanitized) EXPECT_LT(r.maxrss_kb, 1024 * 1024) << "kB";
}

// A data window edited wider than the chunks hold (the chunk count unchanged): OpenEXR's InputFile
// decoded each chunk short and filled the rest with zeros or the previous chunk's bytes, so
// verify passed such a file (exit 0, a red 0.29 below zero) and sample, render and plot showed
// pixels it does not hold. Every reader refuses it, naming the file and the damaged chunk, for a
// compressed and an uncompressed file.
TEST(HostileReads, ADataWindowWiderThanItsChunksIsRefusedByEveryReader) {
    ScratchDir d;
    pattern_png(d, "in.png", 16, 16);
    for (const char* compression : {"zip", "piz", "none"}) {
        const std::string exr = d / (std::string(compression) + ".exr");
        ASSERT_EQ(run_spectex({"bake", d / "in.png", "-o", exr, "--method", "basis",
                               "--wavelengths", "400:700:20", "--compression", compression, "-q"})
                      .status,
                  0);
        EXPECT_EQ(run_spectex({"verify", exr}).status, 0) << compression;
        // dataWindow 0,0 - 15,15 becomes 0,0 - 31,15: the same 16 rows, twice the width.
        std::string b = read_file(exr);
        const std::string key = std::string("dataWindow") + '\0' + "box2i" + '\0';
        const size_t at = b.find(key);
        ASSERT_NE(at, std::string::npos);
        const size_t max_x = at + key.size() + 4 + 8;
        ASSERT_EQ(b[max_x], 15);
        b[max_x] = 31;
        const std::string wide = d / (std::string(compression) + "_wide.exr");
        write_bytes(wide, b);
        for (const std::vector<std::string>& args :
             {std::vector<std::string>{"verify", wide},
              {"sample", wide, "5,3"},
              {"render", wide, "-o", d / "r.png"},
              {"plot", wide, "--pixel", "5,3", "-o", d / "p.svg"}}) {
            const RunResult r = run_spectex(args);
            EXPECT_EQ(r.status, 1) << compression << " " << args[0] << ": " << r.out << r.err;
            EXPECT_TRUE(has_text(r.err, wide + ": cannot read the pixels: the chunk of rows "))
                << compression << " " << args[0] << ": " << r.err;
        }
        EXPECT_FALSE(file_exists(d / "r.png"));
        EXPECT_FALSE(file_exists(d / "p.svg"));
    }
}
