#include "pipeline/batch_files.h"

#include <ImfHeader.h>
#include <ImfMultiPartInputFile.h>
#include <ImfStringAttribute.h>
#include <fcntl.h>
#include <limits.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <regex>
#include <sstream>

#include "base/bounded_read.h"
#include "base/error.h"
#include "base/text.h"
#include "io/linearizer.h"
#include "io/paths.h"
#include "pipeline/json_text.h"

namespace spectex {

namespace {

std::string regex_quote(const std::string& s) {
    static const std::string special = R"(\^$.|?*+()[]{})";
    std::string out;
    for (char c : s) {
        if (special.find(c) != std::string::npos) out += '\\';
        out += c;
    }
    return out;
}

}  // namespace

const std::vector<std::string>& template_tokens() {
    static const std::vector<std::string> tokens = {"{dir}", "{reldir}", "{stem}", "{ext}"};
    return tokens;
}

bool has_template_tokens(const std::string& s) {
    for (const auto& t : template_tokens())
        if (s.find(t) != std::string::npos) return true;
    return false;
}

std::string unknown_template_token(const std::string& s) {
    for (size_t open = s.find('{'); open != std::string::npos; open = s.find('{', open + 1)) {
        size_t close = s.find('}', open);
        std::string token =
            close == std::string::npos ? s.substr(open) : s.substr(open, close - open + 1);
        bool known = false;
        for (const auto& t : template_tokens()) known = known || token == t;
        if (!known) return token;
    }
    return "";
}

std::vector<std::string> expand_tiles(const std::string& path) {
    const bool udim = path.find("<UDIM>") != std::string::npos;
    const bool uvtile = path.find("<UVTILE>") != std::string::npos;
    if (!udim && !uvtile) return {path};
    std::string dir = folder_of(path), base = file_name_of(path);
    if (folder_of(path).find('<') != std::string::npos)
        throw Error(path + ": tile tokens are only expanded in the file name, not in folders");
    std::string pattern = regex_quote(base);
    auto replace_all = [&](const std::string& from, const std::string& to) {
        std::string q = regex_quote(from);
        for (size_t pos; (pos = pattern.find(q)) != std::string::npos;)
            pattern.replace(pos, q.size(), to);
    };
    // UDIM = 1001 + u + 10 v with u in 0..9: every four-digit number from 1001 to 9999 is a tile
    // (1010 is u = 9 of the first row, 1011 the first tile of the second).
    replace_all("<UDIM>", "(100[1-9]|10[1-9][0-9]|1[1-9][0-9][0-9]|[2-9][0-9][0-9][0-9])");
    replace_all("<UVTILE>", "u[1-9][0-9]*_v[1-9][0-9]*");
    std::regex re(pattern);
    std::vector<std::string> out;
    namespace fs = std::filesystem;
    std::error_code ec;
    fs::directory_iterator it(dir, ec);
    if (ec) throw Error(path + ": cannot list " + dir + ": " + ec.message());
    // Names as the system gives them (native bytes, whatever their encoding), put in the place of
    // the pattern's name: the folder stays as the user spelt it ("a//b/", "./", none).
    for (const fs::directory_iterator end; !ec && it != end; it.increment(ec)) {
        const fs::path name = it->path().filename();
        if (std::regex_match(name.native(), re))
            out.push_back(fs::path(path).replace_filename(name).native());
    }
    if (ec) throw Error(path + ": cannot list " + dir + ": " + ec.message());
    if (out.empty()) throw Error(path + ": no existing tiles match");
    std::sort(out.begin(), out.end());
    return out;
}

std::vector<std::string> read_list(const std::string& file) {
    // The list is a regular file of bounded size, checked before it is read (never a device or
    // folder), standard input ("-"), or a pipe (a FIFO, or a shell's <(find ...)), which like
    // standard input may hold anything and is read up to the same limit. A pipe is opened without
    // blocking, so one with no writer reads as empty and is refused, never waited on. It is parsed
    // as it is read, so that binary data is refused at its first bad byte: a NUL or another
    // control character, or a line longer than PATH_MAX, names the line and stops.
    const bool is_stdin = file == "-";
    struct stat st;
    const bool is_pipe = !is_stdin && ::stat(file.c_str(), &st) == 0 && S_ISFIFO(st.st_mode);
    const std::string name = is_stdin ? "standard input (--from-list -)" : file;
    std::unique_ptr<CheckedFile> checked;
    std::unique_ptr<int, void (*)(int*)> pipe_fd(nullptr, [](int* p) {
        ::close(*p);
        delete p;
    });
    if (is_pipe) {
        const int p = ::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
        if (p < 0) throw Error(file + ": " + std::strerror(errno));
        pipe_fd.reset(new int(p));
        struct stat fst;
        if (::fstat(p, &fst) != 0 || !S_ISFIFO(fst.st_mode))
            throw Error(file + ": the file changed while it was being opened");
        const int fl = ::fcntl(p, F_GETFL);
        if (fl >= 0) (void)::fcntl(p, F_SETFL, fl & ~O_NONBLOCK);
    } else if (!is_stdin) {
        checked = std::make_unique<CheckedFile>(file, file_limits::kInputList, "an input list");
    }
    const int fd = is_stdin ? 0 : is_pipe ? *pipe_fd : checked->fd();

    std::vector<std::string> out;
    std::string line;
    size_t lineno = 1;
    uint64_t total = 0;
    auto bad = [&](const std::string& why) {
        return Error(name + ": line " + std::to_string(lineno) + ": " + why);
    };
    auto control = [&](unsigned char c) {
        char hex[8];
        std::snprintf(hex, sizeof hex, "0x%02x", c);
        return bad(std::string("control character ") + hex +
                   ": binary data, not a list of paths (one per line)");
    };
    auto finish_line = [&] {
        if (!line.empty() && line.back() == '\r') line.pop_back();  // CRLF lists
        if (line.find('\r') != std::string::npos) throw control('\r');
        if (line.size() >= PATH_MAX)
            throw bad("longer than PATH_MAX (" + std::to_string(PATH_MAX) + " bytes): not a path");
        // Spaces and tabs around a path are the list's, not the path's (a list written by hand or
        // by a spreadsheet); a path that really starts or ends with one goes on the command line.
        const size_t b = line.find_first_not_of(" \t"), e = line.find_last_not_of(" \t");
        line = b == std::string::npos ? std::string() : line.substr(b, e - b + 1);
        if (!line.empty() && line[0] != '#') {
            if (out.size() >= file_limits::kInputListEntries)
                throw bad("more than " + std::to_string(file_limits::kInputListEntries) +
                          " paths in one list: split it (or bake it with --shard)");
            out.push_back(line);
        }
        line.clear();
        ++lineno;
    };
    char buf[65536];
    for (;;) {
        ssize_t n = ::read(fd, buf, sizeof buf);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw Error(name + ": read error: " + std::strerror(errno));
        }
        if (n == 0) break;
        total += static_cast<uint64_t>(n);
        if (total > file_limits::kInputList)
            throw Error(name + ": an input list may not exceed " +
                        format_bytes(file_limits::kInputList));
        for (ssize_t i = 0; i < n; ++i) {
            const unsigned char c = static_cast<unsigned char>(buf[i]);
            if (c == '\n') {
                finish_line();
                continue;
            }
            if (c == 0) throw bad("NUL byte: binary data, not a list of paths (one per line)");
            if ((c < 0x20 && c != '\t' && c != '\r') || c == 0x7f) throw control(c);
            // PATH_MAX counts the terminating NUL; one more byte for a CR before the newline.
            if (line.size() >= PATH_MAX)
                throw bad("longer than PATH_MAX (" + std::to_string(PATH_MAX) +
                          " bytes): not a path");
            line += static_cast<char>(c);
        }
    }
    if (!line.empty()) finish_line();
    if (is_pipe && total == 0)
        throw Error(file + ": a FIFO with no writer, or nothing written to it: no list to read");
    return out;
}

std::string relative_folder(const std::string& input, const std::string& base_dir) {
    namespace fs = std::filesystem;
    const fs::path in = fs::absolute(fs::path(input)).lexically_normal();
    const fs::path base = fs::absolute(fs::path(base_dir)).lexically_normal();
    fs::path rel = in.parent_path().lexically_relative(base);
    if (rel.empty() && in.parent_path() != base)
        throw Error(input + ": not below the --base-dir " + base_dir +
                    " (inputs of a mirrored tree must lie in it)");
    if (rel.empty()) rel = ".";
    for (const auto& part : rel)
        if (part == "..")
            throw Error(input + ": not below the --base-dir " + base_dir +
                        " (inputs of a mirrored tree must lie in it)");
    std::string out = rel.generic_string();
    while (out.size() > 1 && out.back() == '/') out.pop_back();
    return out;
}

std::string output_for(const std::string& input, const std::string& templ,
                       const std::string& output_dir, const std::string& base_dir) {
    std::string base = file_name_of(input);
    size_t dot = base.find_last_of('.');
    std::string stem = dot == std::string::npos || dot == 0 ? base : base.substr(0, dot);
    std::string ext = dot == std::string::npos || dot == 0 ? "" : base.substr(dot + 1);
    std::string pattern = templ;
    if (!output_dir.empty()) {
        std::string dir = output_dir;
        while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
        pattern = dir + (dir == "/" ? "" : "/") +
                  (has_template_tokens(templ) ? templ
                   : base_dir.empty()         ? "{stem}.exr"
                                              : "{reldir}/{stem}.exr");
    }
    const bool wants_reldir = pattern.find("{reldir}") != std::string::npos;
    if (wants_reldir && base_dir.empty())
        throw Error("the output template '" + pattern +
                    "' uses {reldir}, which needs --base-dir DIR");
    const std::string reldir = wants_reldir ? relative_folder(input, base_dir) : "";
    // {dir} under --output-dir: the input's folder as a path inside it ("/abs/x" as "abs/x", never
    // "..").
    std::string dir_value = folder_of(input);
    if (!output_dir.empty() && pattern.find("{dir}") != std::string::npos) {
        while (!dir_value.empty() && dir_value.front() == '/') dir_value.erase(0, 1);
        if (dir_value.empty()) dir_value = ".";
        for (size_t b = 0; b <= dir_value.size();) {
            size_t e = dir_value.find('/', b);
            if (e == std::string::npos) e = dir_value.size();
            if (dir_value.compare(b, e - b, "..") == 0)
                throw Error(input + ": {dir} would climb out of --output-dir " + output_dir +
                            " (its folder has '..'); give --base-dir and use {reldir}");
            b = e + 1;
        }
    }
    // Folder by folder, so that a name such as "...png" (stem "..") cannot add a "." or ".."
    // component, or an empty one, that the template did not have: an output never climbs out of
    // the folder the template names. {dir} is the input's own folder, as the user spelled it.
    std::string out;
    for (size_t begin = 0;;) {
        size_t slash = pattern.find('/', begin);
        std::string part =
            pattern.substr(begin, slash == std::string::npos ? std::string::npos : slash - begin);
        std::string sub = part;
        auto replace = [&](const std::string& token, const std::string& value) {
            for (size_t pos = 0; (pos = sub.find(token, pos)) != std::string::npos;
                 pos += value.size())
                sub.replace(pos, token.size(), value);
        };
        const bool user_folder =
            part.find("{dir}") != std::string::npos || part.find("{reldir}") != std::string::npos;
        replace("{stem}", stem);
        replace("{ext}", ext);
        replace("{reldir}", reldir);
        replace("{dir}", dir_value);
        if (!user_folder && sub != part && (sub.empty() || sub == "." || sub == ".."))
            throw Error(
                input + ": the output template '" + pattern + "' makes the path component '" + sub +
                "' of this input's name, which would leave the folder it names; rename the file or "
                "change the template");
        // A file at the top of --base-dir: "out/{reldir}/x.exr" is "out/x.exr", not "out/./x.exr".
        if (part == "{reldir}" && sub == "." && slash != std::string::npos) {
            begin = slash + 1;
            continue;
        }
        out += sub;
        if (slash == std::string::npos) break;
        out += '/';
        begin = slash + 1;
    }
    return out;
}

Shard Shard::parse(const std::string& spec) {
    // Strict: digits only on each side of the one slash, no sign, no wrap-around (4294967297 is
    // not 1): a farm's array index that went wrong must fail, not bake everything.
    const size_t slash = spec.find('/');
    long long k = 0, n = 0;
    const bool ok = slash != std::string::npos && spec[0] != '-' &&
                    parse_whole(spec.substr(0, slash), 1, 1000000000, &k) &&
                    parse_whole(spec.substr(slash + 1), 1, 1000000000, &n) && k <= n;
    if (!ok) throw Error("--shard '" + spec + "': expected K/N with 1 <= K <= N, e.g. 3/10");
    return Shard{static_cast<int>(k), static_cast<int>(n)};
}

const char* to_string(BatchStatus s) {
    switch (s) {
        case BatchStatus::Ok:
            return "ok";
        case BatchStatus::Skipped:
            return "skipped";
        case BatchStatus::Failed:
            return "failed";
    }
    return "failed";
}

std::vector<std::string> file_warnings(const BakeResult& r, bool default_rule) {
    std::vector<std::string> w = r.notes;
    // Values outside [0, 1] by no more than a config's own arithmetic (the rounding of published
    // matrices: an sRGB texture through an ACES 1.x config has its white's green at 1 + 8.5e-5)
    // are clamped and counted, not warned about: a warning on nearly every texture buried the
    // ones that mean something (a wide gamut, HDR values, the wrong colour space).
    if (r.clamped_pixels && r.clamped_excursion > kConfigArithmeticTolerance) {
        char by[32];
        std::snprintf(by, sizeof by, "%.3g", static_cast<double>(r.clamped_excursion));
        w.push_back(std::to_string(r.clamped_pixels) +
                    " pixels had linear values outside [0, 1] and were clamped (by up to " + by +
                    ")");
    }
    if (r.replaced_pixels)
        w.push_back(std::to_string(r.replaced_pixels) +
                    " pixels had NaN/Inf values replaced with 0");
    if (default_rule && r.integer_to_linear_by_default_rule)
        w.push_back("an integer (display-referred) file read as '" + r.colorspace +
                    "', a scene-linear space, only because the OCIO config's default file rule '" +
                    r.colorspace_rule +
                    "' names it; if it is an sRGB texture, bake it with "
                    "--colorspace");
    return w;
}

std::string json_record(const FileRecord& r) {
    Json j;
    j["schema_version"] = kJsonSchemaVersion;
    put_text(j, "input", r.input);
    put_text(j, "output", r.output);
    j["status"] = to_string(r.status);
    put_text_or_null(j, "error", r.error);
    j["seconds"] = json_number(r.result.seconds, "%.3f");
    j["pixels"] = r.result.pixels;
    j["bins"] = r.result.bins;
    j["bytes"] = r.result.bytes;
    j["clamped_pixels"] = r.result.clamped_pixels;
    j["clamped_excursion"] = json_number(r.result.clamped_excursion, "%.9g");
    j["replaced_pixels"] = r.result.replaced_pixels;
    put_text(j, "colorspace", r.result.colorspace);
    put_text(j, "colorspace_from", r.result.colorspace_how);  // how it was chosen
    put_texts(j, "warnings",
              r.status == BatchStatus::Ok ? file_warnings(r.result) : std::vector<std::string>());
    put_text(j, "settings_hash", r.settings_hash);
    if (r.status == BatchStatus::Skipped)
        put_text(j, "reason", r.reason);  // why nothing was done, for a script
    if (r.status == BatchStatus::Ok) {
        const auto& st = r.result.stages;
        Json stages;
        stages["writer"] = st.writer;
        const std::pair<const char*, double> times[] = {{"read_s", st.read},
                                                        {"colour_s", st.colour},
                                                        {"expand_s", st.expand},
                                                        {"pack_s", st.pack},
                                                        {"encoder_wait_s", st.encoder_wait},
                                                        {"producer_wait_s", st.producer_wait},
                                                        {"compress_cpu_s", st.compress_cpu},
                                                        {"finish_s", st.finish}};
        for (const auto& [key, seconds] : times) stages[key] = json_number(seconds, "%.4f");
        j["stages"] = std::move(stages);
    }
    return json_line(j);
}

std::string json_interrupted_record(const std::string& signal, size_t files, size_t finished,
                                    size_t stopped, const std::string& settings_hash) {
    Json j;
    j["schema_version"] = kJsonSchemaVersion;
    j["status"] = "interrupted";
    put_text(j, "signal", signal);
    j["files"] = files;
    j["finished"] = finished;
    j["stopped"] = stopped;  // inside their bake: no output, temporaries removed
    j["not_started"] = files - finished - stopped;
    put_text(j, "settings_hash", settings_hash);
    return json_line(j);
}

const char* to_string(DryRunAction a) {
    switch (a) {
        case DryRunAction::Bake:
            return "would_bake";
        case DryRunAction::Skip:
            return "would_skip";
        case DryRunAction::Fail:
            return "would_fail";
    }
    return "would_fail";
}

std::string json_dry_run_record(const DryRunFile& f, const std::string& settings_hash) {
    Json j;
    j["schema_version"] = kJsonSchemaVersion;
    j["dry_run"] = true;
    put_text(j, "input", f.input);
    put_text(j, "output", f.output);
    j["status"] = to_string(f.action);
    put_text_or_null(j, "error", f.error);
    j["update_would_skip"] = f.update.up_to_date;
    put_text(j, "reason", f.update.reason);  // why --update skips it, or why it does not
    if (f.action == DryRunAction::Bake) {
        j["width"] = f.width;
        j["height"] = f.height;
        j["channels"] = f.channels;
        put_text(j, "format", f.format);
        put_text(j, "colorspace", f.colorspace);
        put_text(j, "colorspace_from", f.colorspace_how);
    }
    put_text(j, "settings_hash", settings_hash);
    return json_line(j);
}

}  // namespace spectex
