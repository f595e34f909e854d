#pragma once
// Helpers for end-to-end tests: run the real spectex binary, make scratch folders and images.
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

extern char** environ;

namespace spectex_test {

struct RunResult {
    int status = -1;          // exit status, or 128+signal
    std::string out, err;
};

inline std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// Runs SPECTEX_BINARY with args; extra_env entries "NAME=value" are added to the environment.
inline RunResult run_spectex(const std::vector<std::string>& args, const std::vector<std::string>& extra_env = {}) {
    char tmpl[] = "/tmp/spectex-run-XXXXXX";
    std::string dir = mkdtemp(tmpl);
    std::string out = dir + "/out", err = dir + "/err";
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<std::string> argv_s{SPECTEX_BINARY};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> env_s;
    for (char** e = environ; *e; ++e) env_s.emplace_back(*e);
    env_s.insert(env_s.end(), extra_env.begin(), extra_env.end());
    std::vector<char*> envp;
    for (auto& e : env_s) envp.push_back(e.data());
    envp.push_back(nullptr);
    pid_t pid;
    RunResult r;
    if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), envp.data()) == 0) {
        int st = 0;
        waitpid(pid, &st, 0);
        r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    }
    posix_spawn_file_actions_destroy(&fa);
    r.out = read_file(out);
    r.err = read_file(err);
    unlink(out.c_str());
    unlink(err.c_str());
    rmdir(dir.c_str());
    return r;
}

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
inline void write_image(const std::string& path, int w, int h, int nch, OIIO::TypeDesc format, const void* pixels,
                        const std::vector<std::pair<std::string, std::string>>& attrs = {}, int tile = 0) {
    OIIO::ImageSpec spec(w, h, nch, format);
    if (tile > 0) {
        spec.tile_width = tile;
        spec.tile_height = tile;
    }
    for (const auto& [k, v] : attrs) spec.attribute(k, v);
    auto out = OIIO::ImageOutput::create(path);
    if (!out || !out->open(path, spec) || !out->write_image(format, pixels) || !out->close())
        throw std::runtime_error("cannot write test image " + path + ": " + OIIO::geterror());
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

}  // namespace spectex_test
