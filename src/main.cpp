// spectex: sRGB textures to spectral reflectance OpenEXR. main and subcommand dispatch only; the
// helpers every command shares (cli/commands.h) are in cli/commands.cpp.
#include <cerrno>
#include <clocale>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "io/atomic_file.h"
#include "io/library_stderr.h"
#include "spectex/version.h"

namespace {

const char* kUsage =
    "Usage: spectex <command> [options]\n"
    "\n"
    "Spectral reflectance OpenEXR textures from sRGB (and other) textures. By default each pixel\n"
    "becomes a spectrum interpolated between exact spectra on a 9^3 RGB lattice (LHTSS prior),\n"
    "keeping the mantissa bits six common lights can see (other methods: 'spectex bake --help').\n"
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

}  // namespace

// The command as given, shell-quoted: printed once at the end of a run whose work failed, so that a
// farm log holds what to rerun (as oiiotool does).
std::string g_command_line;

// What a command printed must have reached standard output: a full disk or a closed pipe behind
// it (`> /dev/full`) is a failure, never exit 0 with the output lost.
int finish(int status) {
    std::cout.flush();
    errno = 0;
    if (std::fflush(stdout) != 0 || std::ferror(stdout) || !std::cout) {
        const int err = errno;
        spectex::print_error(std::string("standard output: cannot write: ") +
                             (err ? std::strerror(err) : "write error"));
        if (status == 0) status = 1;
    }
    spectex::finish_library_stderr();  // the libraries' last warnings before the closing line
    if (status == 1 && !g_command_line.empty())
        std::cerr << "spectex: the command was: " << spectex::one_line(g_command_line) << std::endl;
    // A batch stopped by SIGTERM, SIGINT or SIGHUP (io/atomic_file.h): its last line names the
    // signal, then the process ends by it, as it would have without the batch's report.
    if (const int sig = spectex::termination_requested()) {
        std::cerr << "spectex: interrupted by " << spectex::signal_name(sig)
                  << ": the files finished are kept (each recorded in a --json report), the "
                     "others were not baked and left nothing behind; ending by "
                  << spectex::signal_name(sig) << " (exit status " << 128 + sig << " in a shell)"
                  << std::endl;
        spectex::end_by_signal(sig);
    }
    return status;
}

int run(int argc, char** argv);

int main(int argc, char** argv) { return finish(run(argc, argv)); }

int run(int argc, char** argv) {
    // Channel names hold commas and numbers are parsed with strtod: one locale, always.
    std::setlocale(LC_ALL, "C");
    std::locale::global(std::locale::classic());
    spectex::note_inherited_descriptors();  // before anything is opened: only these are streams
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
    for (const auto& a : args) command_line += " " + spectex::quote_path(a);
    g_command_line = command_line;
    std::vector<std::string> rest(args.begin() + 1, args.end());
    if (cmd == "bake") return spectex::run_bake(rest);
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
