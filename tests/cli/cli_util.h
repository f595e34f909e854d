#pragma once
// Helpers for end-to-end tests: run the real spectex binary, make scratch folders and images.
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

// The default bake's grid without --wavelengths (DefaultBake::grid): 400:700:10, 31 bins. Other
// methods, and --wavelengths 380:780:5, take 81 bins. The golden bakes hold the default to it.
constexpr size_t kDefaultBins = 31;
constexpr const char* kDefaultGrid = "400:700:10";

// The spectex under test is built with AddressSanitizer: tests/sanitize/run.sh runs this (Release)
// harness against its instrumented binary with $SPECTEX_TEST_BINARY and
// SPECTEX_TEST_BINARY_SANITIZED=1 (a harness compiled with ASan runs its own build's binary). Such
// a binary reserves terabytes of address space for its shadow and faults in more pages, so memory
// bounds are set and scaled for it.
#if defined(__SANITIZE_ADDRESS__)
#define SPECTEX_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SPECTEX_TEST_ASAN 1
#endif
#endif

namespace spectex_test {

inline const bool kBinarySanitized = [] {
#ifdef SPECTEX_TEST_ASAN
    return true;
#else
    const char* s = std::getenv("SPECTEX_TEST_BINARY_SANITIZED");
    return s != nullptr && std::string(s) == "1";
#endif
}();

// The spectex under test: SPECTEX_BINARY (this build's), or $SPECTEX_TEST_BINARY (another build's:
// the sanitized one, or an older commit's to compare).
inline std::string spectex_binary() {
    const char* other = std::getenv("SPECTEX_TEST_BINARY");
    return other && *other ? other : SPECTEX_BINARY;
}

// Every spectex this binary runs keeps its answers (plans, --precision auto's bits) in a cache of
// the test run's own, never the user's ~/.cache/spectex: a folder of the build tree named by the
// size and time of the spectex under test, so a rebuilt binary starts with an empty one. The
// default bake chooses its bits once per build instead of once per test; a test of the cache
// names a folder of its own, and --no-cache or SPECTEX_CACHE_DIR= (empty) turn it off.
inline const bool kTestCacheSet = [] {
    struct stat st {};
    std::string dir = SPECTEX_TEST_CACHE_ROOT;
    if (::stat(spectex_binary().c_str(), &st) == 0)
        dir += "/" + std::to_string(st.st_size) + "-" + std::to_string(st.st_mtim.tv_sec) + "." +
               std::to_string(st.st_mtim.tv_nsec);
    ::setenv("SPECTEX_CACHE_DIR", dir.c_str(), 1);
    return true;
}();

struct RunResult {
    int status = -1;  // exit status, or 128+signal
    std::string out, err;
};

inline std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// A null-terminated argv/envp array pointing into `strings` (which must outlive it).
inline std::vector<char*> c_array(std::vector<std::string>& strings) {
    std::vector<char*> v;
    for (auto& s : strings) v.push_back(s.data());
    v.push_back(nullptr);
    return v;
}

// {spectex_binary(), args...}.
inline std::vector<std::string> spectex_argv(const std::vector<std::string>& args) {
    std::vector<std::string> v{spectex_binary()};
    v.insert(v.end(), args.begin(), args.end());
    return v;
}

// This process's environment plus extra "NAME=value" entries, which replace this process's own
// (getenv takes the first of two entries with one name: the harness's SPECTEX_CACHE_DIR would win).
inline std::vector<std::string> environment_with(const std::vector<std::string>& extra) {
    auto name_of = [](const std::string& e) { return e.substr(0, e.find('=') + 1); };
    std::vector<std::string> v;
    for (char** e = environ; *e; ++e) {
        const std::string entry = *e;
        bool replaced = false;
        for (const auto& x : extra) replaced = replaced || name_of(x) == name_of(entry);
        if (!replaced) v.push_back(entry);
    }
    v.insert(v.end(), extra.begin(), extra.end());
    return v;
}

// Runs SPECTEX_BINARY with args; extra_env entries "NAME=value" are added to the environment;
// standard input from `stdin_path` ("" = this process's) and, when `stdout_path` is given, standard
// output written there instead of captured (e.g. /dev/full).
inline RunResult run_spectex_io(const std::vector<std::string>& args, const std::string& stdin_path,
                                const std::string& stdout_path = "",
                                const std::vector<std::string>& extra_env = {}) {
    char tmpl[] = "/tmp/spectex-run-XXXXXX";
    std::string dir = mkdtemp(tmpl);
    std::string out = stdout_path.empty() ? dir + "/out" : stdout_path, err = dir + "/err";
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    if (!stdin_path.empty())
        posix_spawn_file_actions_addopen(&fa, 0, stdin_path.c_str(), O_RDONLY, 0);
    posix_spawn_file_actions_addopen(
        &fa, 1, out.c_str(), O_WRONLY | O_CREAT | (stdout_path.empty() ? O_TRUNC : 0), 0644);
    posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<std::string> argv_s = spectex_argv(args), env_s = environment_with(extra_env);
    std::vector<char*> argv = c_array(argv_s), envp = c_array(env_s);
    pid_t pid;
    RunResult r;
    if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), envp.data()) == 0) {
        int st = 0;
        waitpid(pid, &st, 0);
        r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    }
    posix_spawn_file_actions_destroy(&fa);
    if (stdout_path.empty()) {
        r.out = read_file(out);
        unlink(out.c_str());
    }
    r.err = read_file(err);
    unlink(err.c_str());
    rmdir(dir.c_str());
    return r;
}

inline RunResult run_spectex(const std::vector<std::string>& args,
                             const std::vector<std::string>& extra_env = {}) {
    return run_spectex_io(args, "", "", extra_env);
}

// Runs a bash command line (for what needs a shell: process substitution, make, cd), capturing
// standard output and standard error together in `out`, and the exit status.
inline RunResult run_shell(const std::string& script) {
    RunResult r;
    const std::string cmd = "bash -c '" + [&] {
        std::string q;
        for (char c : script) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
        return q;
    }() + "' 2>&1";
    FILE* p = ::popen(cmd.c_str(), "r");
    if (!p) return r;
    char buf[4096];
    for (size_t k; (k = std::fread(buf, 1, sizeof buf, p)) > 0;) r.out.append(buf, k);
    const int st = ::pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128;
    return r;
}

// The spectex binary the tests run ($SPECTEX_TEST_BINARY or the build's).
// A scratch folder removed (with its files) at the end of the test.
class ScratchDir {
  public:
    ScratchDir() {
        char tmpl[] = "/tmp/spectex-test-XXXXXX";
        path_ = mkdtemp(tmpl);
    }
    ~ScratchDir() { std::system(("rm -rf '" + path_ + "'").c_str()); }
    const std::string& path() const { return path_; }
    std::string operator/(const std::string& name) const { return path_ + "/" + name; }

  private:
    std::string path_;
};

// Writes an image with OpenImageIO: pixels are nchannels interleaved values of `format`.
// Writes `pixels` (in `format`, packed as `spec` lays them out) under `spec`: channel names, per
// channel formats, data window, attributes.
inline void write_image(const std::string& path, const OIIO::ImageSpec& spec, OIIO::TypeDesc format,
                        const void* pixels) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out || !out->open(path, spec) || !out->write_image(format, pixels) || !out->close())
        throw std::runtime_error("cannot write test image " + path + ": " + OIIO::geterror());
}

inline void write_image(const std::string& path, int w, int h, int nch, OIIO::TypeDesc format,
                        const void* pixels,
                        const std::vector<std::pair<std::string, std::string>>& attrs = {},
                        int tile = 0) {
    OIIO::ImageSpec spec(w, h, nch, format);
    if (tile > 0) {
        spec.tile_width = tile;
        spec.tile_height = tile;
    }
    for (const auto& [k, v] : attrs) spec.attribute(k, v);
    write_image(path, spec, format, pixels);
}

// An 8-bit RGB PNG whose pixels depend on `seed`: another seed, another picture of the same size.
inline void write_pattern_png(const std::string& path, int seed, int w = 8, int h = 8) {
    std::vector<uint8_t> px(static_cast<size_t>(w * h * 3));
    for (size_t i = 0; i < px.size(); ++i)
        px[i] = static_cast<uint8_t>((i * 37 + static_cast<size_t>(seed) * 11) & 255);
    write_image(path, w, h, 3, OIIO::TypeDesc::UINT8, px.data());
}

// A 4x4 binary PPM whose pixels depend on `seed`: every one has the same byte size, so a
// replacement keeps the size and only the content hash can tell.
inline void write_pattern_ppm(const std::string& path, int seed) {
    std::string bytes = "P6\n4 4\n255\n";
    for (int i = 0; i < 48; ++i) bytes.push_back(static_cast<char>((i * 29 + seed * 13) & 255));
    std::ofstream(path, std::ios::binary) << bytes;
}

// write_pattern_png's picture for seed 0 at d/name, returning its path: for tests whose pixels
// only need to be an ordinary colour image.
inline std::string pattern_png(const ScratchDir& d, const std::string& name, int w, int h) {
    const std::string path = d / name;
    write_pattern_png(path, 0, w, h);
    return path;
}

// A 16x16 8-bit sRGB ramp at d/albedo.png, returning its path: saturated and dark colours, the
// ones a lossy compression (b44) moves most.
inline std::string write_albedo(const ScratchDir& d) {
    std::vector<unsigned char> px(16 * 16 * 3);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            unsigned char* p = &px[(y * 16 + x) * 3];
            p[0] = static_cast<unsigned char>(x * 17);
            p[1] = static_cast<unsigned char>(y * 17);
            p[2] = static_cast<unsigned char>(((x + y) % 3) * 120);
        }
    const std::string path = d / "albedo.png";
    write_image(path, 16, 16, 3, OIIO::TypeDesc::UINT8, px.data());
    return path;
}

// write_albedo's picture baked with the default settings to d/b.exr, returning the EXR's path.
inline std::string bake_albedo(const ScratchDir& d) {
    const std::string exr = d / "b.exr";
    const RunResult r = run_spectex({"bake", write_albedo(d), "-o", exr, "-q"});
    if (r.status != 0) throw std::runtime_error("cannot bake " + exr + ": " + r.err);
    return exr;
}

// Whether `text` holds `what` (a message, a record, a file's text).
inline bool has_text(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
}

// How many times `needle` occurs in `s` (overlaps counted).
inline size_t occurrences(const std::string& s, const std::string& needle) {
    size_t n = 0;
    for (size_t p = s.find(needle); p != std::string::npos; p = s.find(needle, p + 1)) ++n;
    return n;
}

inline bool file_exists(const std::string& p) {
    struct stat st;
    return ::stat(p.c_str(), &st) == 0;
}

// Names in a folder (no . and ..).
inline std::vector<std::string> list_dir(const std::string& dir) {
    std::vector<std::string> v;
    std::string cmd = "ls -A '" + dir + "'";
    FILE* p = popen(cmd.c_str(), "r");
    char buf[4096];
    while (p && fgets(buf, sizeof buf, p)) {
        std::string s(buf);
        if (!s.empty() && s.back() == '\n') s.pop_back();
        v.push_back(s);
    }
    if (p) pclose(p);
    return v;
}

// The folder part of a path ("." when there is none).
inline std::string dir_of(const std::string& p) {
    size_t s = p.find_last_of('/');
    return s == std::string::npos ? "." : (s == 0 ? "/" : p.substr(0, s));
}

// spectex's temporary files (<name>.spectex-XXXXXX.tmp) in a folder (none if it is not one).
inline std::vector<std::string> temp_files_in(const std::string& dir) {
    std::vector<std::string> v;
    struct stat st;
    if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) return v;
    for (const auto& n : list_dir(dir))
        if (n.find(".spectex-") != std::string::npos && n.size() >= 4 &&
            n.compare(n.size() - 4, 4, ".tmp") == 0)
            v.push_back(n);
    return v;
}

// The text of a small OCIO v2 config whose colour space "lut_space" reads `lut_src` through a
// FileTransform nested in a GroupTransform, resolved through `search_path`.
inline std::string lut_config_text(const std::string& search_path, const std::string& lut_src) {
    return "ocio_profile_version: 2\n"
           "search_path: \"" +
           search_path +
           "\"\n"
           "roles:\n  default: lin_srgb\n  scene_linear: lin_srgb\n"
           "file_rules:\n  - !<Rule> {name: Default, colorspace: lin_srgb}\n"
           "displays:\n  d:\n    - !<View> {name: v, colorspace: raw}\n"
           "colorspaces:\n"
           "  - !<ColorSpace>\n    name: raw\n    isdata: true\n"
           "  - !<ColorSpace>\n    name: lin_srgb\n"
           "  - !<ColorSpace>\n    name: lut_space\n"
           "    to_scene_reference: !<GroupTransform>\n      children:\n"
           "        - !<FileTransform> {src: \"" +
           lut_src + "\", interpolation: linear}\n";
}

// Writes `text` to `path` (binary, replacing it); throws when the file cannot be written.
inline void write_text(const std::string& path, const std::string& text) {
    std::ofstream f(path, std::ios::binary);
    f << text;
    if (!f.flush()) throw std::runtime_error("cannot write " + path);
}

// Renames header attributes in place (same length), as a file made before spectex wrote them;
// throws when a key is not in the file.
inline void hide_attributes(const std::string& exr, const std::vector<std::string>& keys) {
    std::string bytes = read_file(exr);
    for (const std::string& key : keys) {
        const size_t at = bytes.find(key + std::string(1, '\0'));
        if (at == std::string::npos) throw std::runtime_error(exr + " has no attribute " + key);
        bytes[at + key.size() - 1] = 'X';
    }
    write_text(exr, bytes);
}

inline std::string replace_all(std::string s, const std::string& from, const std::string& to) {
    for (size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size()))
        s.replace(p, from.size(), to);
    return s;
}

}  // namespace spectex_test
