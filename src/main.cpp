// spectex: sRGB textures to spectral reflectance OpenEXR. Subcommand dispatch only.
#include <clocale>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "cli/commands.h"
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
        // A whole, valid UTF-8 sequence passes (file names in other scripts stay readable).
        size_t len = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
        bool valid = len > 0 && i + len <= text.size();
        for (size_t k = 1; valid && k < len; ++k) valid = (static_cast<unsigned char>(text[i + k]) >> 6) == 0x2;
        if (len == 2 && valid) valid = c >= 0xc2;
        if (c == '\t') {
            out += ' ';
            ++i;
        } else if (len == 1 && c >= 0x20 && c != 0x7f) {
            out += static_cast<char>(c);
            ++i;
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

int main(int argc, char** argv) {
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
    if (cmd == "plan") return spectex::run_plan(rest);
    std::cerr << "spectex: unknown command '" << spectex::one_line(cmd) << "'\n" << kUsage;
    return 2;
}
