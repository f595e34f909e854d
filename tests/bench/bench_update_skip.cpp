// A nightly no-op run: `spectex bake --update` over N textures that are all up to date, and
// `spectex info` over many files, against the floor of reading each output's EXR header alone.
//
// Files (made once per run, in --dir, default a fresh folder under /tmp): one 4x4 PNG written with
// OpenImageIO, baked once by the real binary into an EXR (81 bins, half, zip: the default bake);
// then N sources src/t<i>.png (copies of the PNG's bytes with its modification time) and N outputs
// out/t<i>.exr (copies of the baked EXR, newer than the sources). Every output records what the
// one bake recorded (settings, source size, time and hash), which is what each copy's source has,
// so every file is up to date for this spectex and for one that decides by "output newer than
// input" (the figures before and after a change are made by the same benchmark).
//
// Figures, printed as a table and one JSON line (--json):
//   floor        reading one output's header with OpenEXR's core API (exr_start_read, one string
//                attribute, exr_finish) plus a stat of its source, in this process, per file;
//   batch skip   one `spectex bake --from-list LIST --output-dir out --update` over all N, wall
//                time per file, and its ratio to the floor; the process's peak RSS;
//   one skip     `spectex bake src/t0.png -o out/t0.exr --update`, one process per file (make's
//                way), best and median of --repeat, peak RSS;
//   --version    `spectex --version`, wall time and peak RSS (what starting the tool costs);
//   info         `spectex info` over the first --info-files outputs in one process, per file.
// Peak RSS is measured through /usr/bin/time (0 when it is missing).
// Targets (--check exits 1 when one is missed): N skips in under 10 s at N = 10,000 (1 ms a file),
// a batch skip within 5x the floor, info within 10x the floor (info parses and prints every
// attribute and checks the chunk table, which the floor does not).
//
//   bench_update_skip [--files 10000] [--info-files 2000] [--repeat 20] [--spectex PATH]
//                     [--dir DIR] [--keep] [--json] [--check]
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <openexr.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace {

[[noreturn]] void fail(const std::string& why) {
    std::fprintf(stderr, "bench_update_skip: %s\n", why.c_str());
    std::exit(2);
}

double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

struct Run {
    int status = -1;
    double wall = 0;
    double max_rss_mb = 0;  // of the child
    std::string err;
};

// Runs argv with stdout to /dev/null and stderr to a file; wall time and the child's peak RSS.
// The RSS comes from /usr/bin/time, which forks the command from its own small process: wait4's
// figure for a child spawned from here would include this process's own peak (exec keeps the
// spawner's high-water mark), about 130 MB with OpenImageIO and 10,000 paths loaded.
// Short runs are timed without it (its own start-up would count) and measured once more with it.
Run run(const std::vector<std::string>& args, const std::string& scratch, bool rss = true) {
    const std::string err = scratch + "/stderr.txt", usage = scratch + "/usage.txt";
    const bool timed = rss && ::access("/usr/bin/time", X_OK) == 0;
    std::vector<std::string> full;
    if (timed) full = {"/usr/bin/time", "-o", usage, "-f", "%M"};
    full.insert(full.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (const auto& a : full) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    Run r;
    const double t0 = now();
    pid_t pid;
    if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ) != 0)
        fail("cannot run " + full[0]);
    int st = 0;
    waitpid(pid, &st, 0);
    r.wall = now() - t0;
    posix_spawn_file_actions_destroy(&fa);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    std::ifstream in(err);
    std::stringstream ss;
    ss << in.rdbuf();
    r.err = ss.str();
    if (timed) {
        std::ifstream u(usage);
        std::string line, last;
        while (std::getline(u, line))
            if (!line.empty()) last = line;  // after "Command exited with non-zero status N"
        r.max_rss_mb = std::atof(last.c_str()) / 1024.0;
    }
    return r;
}

std::string read_all(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail("cannot read " + path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void write_all(const std::string& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) fail("cannot write " + path);
}

void set_mtime(const std::string& path, const struct timespec& t) {
    struct timespec ts[2] = {t, t};
    if (::utimensat(AT_FDCWD, path.c_str(), ts, 0) != 0) fail("cannot set the time of " + path);
}

void quiet(exr_const_context_t, exr_result_t, const char*) {}

// The floor of one skip: what deciding needs at the least (the source's stat, the output's header
// read with OpenEXR's core API and one attribute looked up), nothing else.
bool floor_one(const std::string& src, const std::string& exr) {
    struct stat st;
    if (::stat(src.c_str(), &st) != 0) return false;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    exr_context_t ctx = nullptr;
    if (exr_start_read(&ctx, exr.c_str(), &init) != EXR_ERR_SUCCESS) return false;
    const exr_attribute_t* a = nullptr;
    const bool ok =
        exr_get_attribute_by_name(ctx, 0, "spectex:settingsHash", &a) == EXR_ERR_SUCCESS && a &&
        a->type == EXR_ATTR_STRING;
    exr_finish(&ctx);
    return ok;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
    int files = 10000, info_files = 2000, repeat = 20;
    std::string spectex = SPECTEX_BINARY, dir;
    bool keep = false, json = false, check = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto val = [&]() -> std::string {
            if (i + 1 >= argc) fail("missing value for " + a);
            return argv[++i];
        };
        if (a == "--files")
            files = std::stoi(val());
        else if (a == "--info-files")
            info_files = std::stoi(val());
        else if (a == "--repeat")
            repeat = std::stoi(val());
        else if (a == "--spectex")
            spectex = val();
        else if (a == "--dir")
            dir = val();
        else if (a == "--keep")
            keep = true;
        else if (a == "--json")
            json = true;
        else if (a == "--check")
            check = true;
        else
            fail("unknown option " + a +
                 " (--files N --info-files M --repeat K --spectex PATH --dir DIR --keep --json "
                 "--check)");
    }
    if (files < 1 || info_files < 0 || repeat < 1) fail("--files, --repeat must be >= 1");
    info_files = std::min(info_files, files);
    if (dir.empty()) {
        char tmpl[] = "/tmp/bench_update_skip-XXXXXX";
        if (!::mkdtemp(tmpl)) fail("cannot make a scratch folder");
        dir = tmpl;
    } else if (::mkdir(dir.c_str(), 0777) != 0 && errno != EEXIST) {
        fail("cannot make " + dir);
    }
    const std::string src_dir = dir + "/src", out_dir = dir + "/out";
    ::mkdir(src_dir.c_str(), 0777);
    ::mkdir(out_dir.c_str(), 0777);

    // One tiny texture, baked once by the binary under test.
    const std::string png = dir + "/tex.png", exr = dir + "/tex.exr";
    {
        const int w = 4, h = 4;
        std::vector<unsigned char> px(static_cast<size_t>(w * h * 3));
        for (size_t k = 0; k < px.size(); ++k) px[k] = static_cast<unsigned char>(k * 37 + 11);
        auto out = OIIO::ImageOutput::create(png);
        OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
        if (!out || !out->open(png, spec) || !out->write_image(OIIO::TypeDesc::UINT8, px.data()) ||
            !out->close())
            fail("cannot write " + png);
    }
    const Run bake = run({spectex, "bake", "-q", png, "-o", exr}, dir);
    if (bake.status != 0) fail("the first bake failed: " + bake.err);
    const std::string png_bytes = read_all(png), exr_bytes = read_all(exr);
    struct stat pst;
    ::stat(png.c_str(), &pst);
    struct timespec out_time = pst.st_mtim;
    out_time.tv_sec += 10;  // outputs newer than their sources (the old rule)

    const double t_make = now();
    std::string list;
    std::vector<std::string> srcs, outs;
    for (int i = 0; i < files; ++i) {
        const std::string s = src_dir + "/t" + std::to_string(i) + ".png",
                          o = out_dir + "/t" + std::to_string(i) + ".exr";
        write_all(s, png_bytes);
        set_mtime(s, pst.st_mtim);
        write_all(o, exr_bytes);
        set_mtime(o, out_time);
        srcs.push_back(s);
        outs.push_back(o);
        list += s + "\n";
    }
    const std::string list_file = dir + "/list.txt";
    write_all(list_file, list);
    const double make_s = now() - t_make;

    // The floor, in this process (twice: the first pass warms the page cache for everything after).
    double floor_s = 0;
    for (int pass = 0; pass < 2; ++pass) {
        const double t0 = now();
        for (int i = 0; i < files; ++i)
            if (!floor_one(srcs[static_cast<size_t>(i)], outs[static_cast<size_t>(i)]))
                fail("floor: cannot read " + outs[static_cast<size_t>(i)]);
        floor_s = now() - t0;
    }
    const double floor_ms = floor_s * 1000 / files;

    // The batch: every file must be reported up to date.
    const Run batch =
        run({spectex, "bake", "--from-list", list_file, "--output-dir", out_dir, "--update"}, dir);
    const std::string expect = "0 baked, " + std::to_string(files) + " up to date, 0 failed";
    if (batch.status != 0 || batch.err.find(expect) == std::string::npos)
        fail("the batch did not skip every file (exit " + std::to_string(batch.status) +
             "): " + batch.err.substr(0, 2000));
    const double batch_ms = batch.wall * 1000 / files;

    // One process per file: timed alone, then once through /usr/bin/time for the peak RSS.
    std::vector<double> one;
    const std::vector<std::string> one_args{spectex, "bake", srcs[0], "-o", outs[0], "--update"};
    for (int k = 0; k < repeat; ++k) {
        const Run r = run(one_args, dir, false);
        if (r.status != 0 || r.err.find("1 up to date") == std::string::npos)
            fail("the single skip did not skip: " + r.err);
        one.push_back(r.wall * 1000);
    }
    const double one_rss = run(one_args, dir).max_rss_mb;
    std::vector<double> ver;
    for (int k = 0; k < repeat; ++k) {
        const Run r = run({spectex, "--version"}, dir, false);
        if (r.status != 0) fail("spectex --version failed");
        ver.push_back(r.wall * 1000);
    }
    const double ver_rss = run({spectex, "--version"}, dir).max_rss_mb;
    double info_ms = 0, info_rss = 0;
    if (info_files > 0) {
        std::vector<std::string> args{spectex, "info"};
        for (int i = 0; i < info_files; ++i) args.push_back(outs[static_cast<size_t>(i)]);
        const Run r = run(args, dir);
        if (r.status != 0) fail("spectex info failed: " + r.err.substr(0, 2000));
        info_ms = r.wall * 1000 / info_files;
        info_rss = r.max_rss_mb;
    }

    const double batch_ratio = batch_ms / floor_ms, info_ratio = info_ms / floor_ms;
    std::printf("bench_update_skip: %d up-to-date files (made in %.1f s), %s\n", files, make_s,
                spectex.c_str());
    std::printf("| what | ms per file | x floor | peak RSS MB |\n|---|---|---|---|\n");
    std::printf("| floor: header (OpenEXR core) + stat, in process | %.4f | 1.0 | |\n", floor_ms);
    std::printf("| bake --update, one process for all %d (%.2f s) | %.4f | %.1f | %.1f |\n", files,
                batch.wall, batch_ms, batch_ratio, batch.max_rss_mb);
    std::printf(
        "| bake --update, one process per file (median of %d; best %.1f) | %.1f | %.0f | %.1f |\n",
        repeat, *std::min_element(one.begin(), one.end()), median(one), median(one) / floor_ms,
        one_rss);
    std::printf("| spectex --version (median of %d) | %.1f | | %.1f |\n", repeat, median(ver),
                ver_rss);
    if (info_files > 0)
        std::printf("| info, one process for %d files | %.4f | %.1f | %.1f |\n", info_files,
                    info_ms, info_ratio, info_rss);
    const double projected_10k = batch_ms * 10000 / 1000;
    std::printf("10,000 skips would take %.1f s (target < 10 s)\n", projected_10k);
    if (json)
        std::printf(
            "{\"files\":%d,\"floor_ms\":%.5f,\"batch_s\":%.4f,\"batch_ms_per_file\":%.5f,\"batch_x_"
            "floor\":%.3f,"
            "\"batch_peak_rss_mb\":%.1f,\"one_skip_ms\":%.3f,\"one_skip_peak_rss_mb\":%.1f,"
            "\"version_ms\":%.3f,"
            "\"version_peak_rss_mb\":%.1f,\"info_files\":%d,\"info_ms_per_file\":%.5f,\"info_x_"
            "floor\":%.3f,"
            "\"info_peak_rss_mb\":%.1f}\n",
            files, floor_ms, batch.wall, batch_ms, batch_ratio, batch.max_rss_mb, median(one),
            one_rss, median(ver), ver_rss, info_files, info_ms, info_ratio, info_rss);
    if (!keep) {
        const std::string rm = "rm -rf '" + dir + "'";
        if (std::system(rm.c_str()) != 0)
            std::fprintf(stderr, "bench_update_skip: could not remove %s\n", dir.c_str());
    }
    if (check) {
        bool ok = projected_10k < 10 && batch_ratio <= 5 && (info_files == 0 || info_ratio <= 10);
        std::printf("targets: %s\n", ok ? "met" : "MISSED");
        return ok ? 0 : 1;
    }
    return 0;
}
