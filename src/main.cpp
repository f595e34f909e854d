// spectex: sRGB textures to spectral reflectance OpenEXR. Subcommand dispatch only.
#include <cerrno>
#include <cstring>
#include <clocale>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "spectral/error.h"
#include "io/atomic_file.h"
#include "io/library_stderr.h"
#include "spectex/version.h"

namespace spectex {

std::string one_line(const std::string& text) {
    std::string out;
    bool pending_break = false;
    for (size_t i = 0; i < text.size();) {
        const unsigned char c = static_cast<unsigned char>(text[i]);
        if (c == '\n' || c == '\r') {
            pending_break = !out.empty();
            ++i;
            continue;
        }
        if (pending_break) {
            while (!out.empty() && out.back() == ' ') out.pop_back();
            out += "; ";
            pending_break = false;
            while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
            continue;
        }
        // A whole, valid UTF-8 sequence passes (file names in other scripts stay readable), unless
        // it is a control (C1) or an invisible format character that reorders or hides text (bidi
        // overrides, zero-width marks): those are written as \uXXXX. Anything else is \xNN.
        size_t len = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
        bool valid = len > 0 && i + len <= text.size();
        for (size_t k = 1; valid && k < len; ++k) valid = (static_cast<unsigned char>(text[i + k]) >> 6) == 0x2;
        uint32_t cp = 0;
        if (valid && len > 1) {
            cp = c & (0x7f >> len);
            for (size_t k = 1; k < len; ++k) cp = (cp << 6) | (static_cast<unsigned char>(text[i + k]) & 0x3f);
            const uint32_t min_cp[5] = {0, 0, 0x80, 0x800, 0x10000};
            valid = cp >= min_cp[len] && cp <= 0x10ffff && !(cp >= 0xd800 && cp <= 0xdfff);  // no overlong, no surrogate
        }
        const bool hidden = valid && len > 1 &&
                            ((cp >= 0x80 && cp <= 0x9f) || (cp >= 0x200b && cp <= 0x200f) ||
                             (cp >= 0x202a && cp <= 0x202e) || (cp >= 0x2060 && cp <= 0x2069) || cp == 0xfeff ||
                             cp == 0x061c || cp == 0x2028 || cp == 0x2029);
        if (c == '\t') {
            out += ' ';
            ++i;
        } else if (len == 1 && c >= 0x20 && c != 0x7f) {
            out += static_cast<char>(c);
            ++i;
        } else if (hidden) {
            char buf[12];
            std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(cp));
            out += buf;
            i += len;
        } else if (len > 1 && valid) {
            out.append(text, i, len);
            i += len;
        } else {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\x%02x", c);
            out += buf;
            ++i;
        }
    }
    return out;
}

void print_error(const std::string& message) { std::cerr << "spectex: " << one_line(message) << std::endl; }

int run_reporting(const std::string& file, const std::function<void()>& work) {
    try {
        work();
        return 0;
    } catch (const Error& e) {
        print_error(e.what());
    } catch (const std::exception& e) {
        print_error(file + ": " + e.what());
    }
    return 1;
}

int usage_error(const std::string& command, const std::string& message) {
    std::cerr << "spectex " << command << ": " << one_line(message) << "\n"
              << "Try 'spectex " << command << " --help'." << std::endl;
    return 2;
}

}  // namespace spectex

namespace {

const char* kUsage =
    "Usage: spectex <command> [options]\n"
    "\n"
    "Spectral reflectance OpenEXR textures from sRGB (and other) textures, with the spectral\n"
    "primary decomposition of Mallett & Yuksel (2019).\n"
    "\n"
    "Commands:\n"
    "  bake     turn a texture into a spectral OpenEXR (channels T.<wavelength>nm)\n"
    "  basis    fit a spectral basis on any wavelength grid, with a certificate\n"
    "  info     describe a spectral OpenEXR\n"
    "  plan     choose the wavelength grid for a scene's lights and an error budget\n"
    "  verify   integrate a spectral OpenEXR back to colour and compare with its source\n"
    "  sample   print the spectra of some pixels, and their colour under lights\n"
    "  render   an sRGB PNG of a spectral OpenEXR as it looks under one or more lights\n"
    "  plot     an SVG plot of the spectra of some pixels\n"
    "\n"
    "Options:\n"
    "  -h, --help     show this help; 'spectex <command> --help' for a command's options\n"
    "  --version      show the version\n"
    "\n"
    "Exit status: 0 success, 1 the work failed, 2 usage error.\n";

std::string quote(const std::string& s) {
    if (!s.empty() && s.find_first_of(" \t\"'\\$`;&|<>()*?") == std::string::npos) return s;
    std::string q = "'";
    for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}

}  // namespace

// What a command printed must have reached standard output: a full disk or a closed pipe behind
// it (`> /dev/full`) is a failure, never exit 0 with the output lost.
int finish(int status) {
    std::cout.flush();
    errno = 0;
    if (std::fflush(stdout) != 0 || std::ferror(stdout) || !std::cout) {
        const int err = errno;
        spectex::print_error(std::string("standard output: cannot write: ") + (err ? std::strerror(err) : "write error"));
        return status == 0 ? 1 : status;
    }
    return status;
}

int run(int argc, char** argv);

int main(int argc, char** argv) { return finish(run(argc, argv)); }

int run(int argc, char** argv) {
    // Channel names hold commas and numbers are parsed with strtod: one locale, always.
    std::setlocale(LC_ALL, "C");
    std::locale::global(std::locale::classic());
    spectex::install_signal_cleanup();
    spectex::capture_library_stderr();

    std::vector<std::string> args(argv + 1, argv + argc);
    if (args.empty()) {
        std::cerr << kUsage;
        return 2;
    }
    const std::string cmd = args[0];
    if (cmd == "-h" || cmd == "--help" || cmd == "help") {
        std::cout << kUsage;
        return 0;
    }
    if (cmd == "--version") {
        std::cout << "spectex " << SPECTEX_VERSION << "\n";
        return 0;
    }
    std::string command_line = "spectex";
    for (const auto& a : args) command_line += " " + quote(a);
    std::vector<std::string> rest(args.begin() + 1, args.end());
    if (cmd == "bake") return spectex::run_bake(rest, command_line);
    if (cmd == "info") return spectex::run_info(rest);
    if (cmd == "basis") return spectex::run_basis(rest, command_line);
    if (cmd == "verify") return spectex::run_verify(rest);
    if (cmd == "sample") return spectex::run_sample(rest);
    if (cmd == "render") return spectex::run_render(rest);
    if (cmd == "plot") return spectex::run_plot(rest);
    if (cmd == "plan") return spectex::run_plan(rest);
    std::cerr << "spectex: unknown command '" << spectex::one_line(cmd) << "'\n" << kUsage;
    return 2;
}
