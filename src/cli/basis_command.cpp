#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include "base/error.h"
#include "cli/arg_parser.h"
#include "cli/commands.h"
#include "cli/output_check.h"
#include "io/atomic_file.h"
#include "io/data_dir.h"
#include "io/file_identity.h"
#include "pipeline/basis_cache.h"
#include "pipeline/light_list.h"
#include "spectral/spectrum.h"

namespace spectex {

namespace {

std::string fmt(double v) {
    if (std::isnan(v)) return "n/a";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
}

}  // namespace

std::string certificate_text(const FitSpec& spec, const FitResult& fit) {
    const FitCertificate& c = fit.certificate;
    std::ostringstream o;
    o << "basis fit: " << spec.describe() << "\n";
    o << "  feasible:                " << (c.feasible ? "yes" : "NO (least-squares closest basis)")
      << "\n";
    o << "  colour residual r,g,b:   " << fmt(c.colour_residual[0]) << ", "
      << fmt(c.colour_residual[1]) << ", " << fmt(c.colour_residual[2])
      << "  (max |RGB(S_k) - e_k|, linear RGB)\n";
    o << "  bound violation:         " << fmt(c.bound_violation) << "  (0 <= S <= 1)\n";
    o << "  sum-to-one violation:    " << fmt(c.sum_violation) << "\n";
    o << "  KKT stationarity:        " << fmt(c.stationarity) << "  (relative)\n";
    o << "  KKT complementarity:     " << fmt(c.complementarity) << "\n";
    o << "  dual sign violation:     " << fmt(c.dual_sign_violation) << "\n";
    o << "  active bounds:           " << c.active_lower << " at 0, " << c.active_upper
      << " at 1 (of " << 3 * fit.basis.size() << ")\n";
    o << "  objective:               " << fmt(c.objective) << "\n";
    o << "  solver:                  " << c.solver_status << ", " << c.iterations << " iterations, "
      << fmt(c.seconds * 1000) << " ms\n";
    return o.str();
}

namespace {

// What the command line said.
struct BasisArgs {
    FitSpec spec;
    std::string output, wavelengths = "380:780:5", wavelengths_file;
    bool wavelengths_given = false;
    std::string objective = "smooth";  // --objective, parsed into spec.objective once checked
    bool stream = false;               // -o names a stream other than "-": written through
    bool quiet = false;
};

void declare_basis_options(ArgParser& p, BasisArgs& a) {
    p.option("-o, --output", "FILE",
             "Basis CSV to write (header row wavelength,r,g,b first, 17 significant digits; its "
             "provenance "
             "and certificate go to FILE.provenance); - for stdout (the CSV alone).",
             [&](const std::string& v) { a.output = stdout_as_dash(v); });
    p.option("--wavelengths", "START:END:STEP", "Wavelength grid in nm (default 380:780:5).",
             [&](const std::string& v) {
                 a.wavelengths = v;
                 a.wavelengths_given = true;
             });
    p.option("--wavelengths-file", "FILE",
             "One wavelength per line (any strictly increasing list).",
             [&](const std::string& v) { a.wavelengths_file = v; });
    observer_option(p, "Observer", a.spec.observer);
    p.option("--illuminant", "NAME|FILE",
             shipped_illuminants_list(FitSpec().illuminant) + " (any case), " +
                 colour_temperature_help() + ", or a CSV wavelength,value.",
             [&](const std::string& v) { a.spec.illuminant = v; });
    p.option("--primaries", "NAME", "srgb (default), rec709, p3, rec2020, or xr,yr,xg,yg,xb,yb.",
             [&](const std::string& v) { a.spec.primaries = v; });
    p.option(
        "--objective", "norm|smooth",
        "smooth (default): least squared first differences along wavelength; norm: least ||S||^2.",
        [&](const std::string& v) { a.objective = v; });
    p.flag("--allow-infeasible",
           "Write the least-squares closest basis when no exact one exists (exit 0).",
           [&] { a.spec.allow_infeasible = true; });
    p.flag("-q, --quiet", "Do not print the certificate.", [&] { a.quiet = true; });
}

// The checks once all options are read; throws UsageError (and Error for an unreadable
// --wavelengths-file).
void check_basis_args(BasisArgs& a, const std::vector<std::string>& pos) {
    FitSpec& spec = a.spec;
    if (!pos.empty()) throw UsageError("unexpected argument '" + pos[0] + "'");
    if (a.output.empty()) throw UsageError("no output file (-o BASIS.csv, or -o - for stdout)");
    check_observer_setting("--observer", spec.observer);
    check_illuminant_setting("--illuminant", spec.illuminant);
    spec.illuminant = light_name(spec.illuminant);
    // A stream other than standard output (standard error, a link into /proc/self/fd) gets
    // the CSV written through, like "-": no sidecar beside it (its folder is /dev or /proc).
    a.stream = a.output != "-" && stream_fd_of(a.output) >= 0;
    if (a.stream) {
        try {
            check_output_path(a.output, true);
        } catch (const Error& e) {
            throw UsageError(e.what());
        }
    }
    if (a.output != "-" && !a.stream) {
        ReadFiles reads;
        reads.add_data_dir(find_data_dir());
        reads.add(spec.observer, "--observer");
        reads.add(spec.illuminant, "--illuminant");
        reads.add(a.wavelengths_file, "--wavelengths-file");
        check_output(a.output, "-o", reads, false, false);
        check_output(basis_provenance_path(a.output), "the provenance of -o", reads, false, false);
    }
    spec.objective = parse_objective_option(a.objective);
    const bool from_file = !a.wavelengths_file.empty();
    if (from_file && a.wavelengths_given)
        throw UsageError("--wavelengths and --wavelengths-file are two grids; give one");
    try {
        spec.grid = from_file ? WavelengthGrid::from_file(a.wavelengths_file)
                              : WavelengthGrid::parse_exact(a.wavelengths);
    } catch (const LimitError& e) {
        throw UsageError(std::string(from_file ? "--wavelengths-file: " : "--wavelengths: ") +
                         e.what());
    } catch (const Error& e) {
        if (from_file) throw;
        throw UsageError(std::string("--wavelengths: ") + e.what());
    }
}

// Fits, prints the certificate, writes the CSV and its sidecar FILE.provenance (the sidecar
// first: a CSV never stands without the record of what made it). Throws Error.
void fit_and_write(BasisArgs& a, const std::string& command_line) {
    FitSpec& spec = a.spec;
    spec.data_dir = find_data_dir();
    FitResult fit = fit_basis_for(spec);
    std::string cert = certificate_text(spec, fit);
    std::ostream& report = a.output == "-" ? std::cerr : std::cout;
    if (!a.quiet) report << cert;
    // The CSV holds the table alone (header row first: generic CSV readers load it); what made
    // it goes to a sidecar, FILE.provenance, one "key: value" line each.
    std::vector<std::string> provenance = {
        "spectral primary decomposition basis (Mallett & Yuksel 2019), fitted by spectex",
        "command: " + command_line,
        "fit: " + spec.describe(),
        "checksum: " + fit.basis.checksum(),
    };
    std::istringstream lines(cert);
    std::string line;
    std::getline(lines, line);  // the first line repeats the fit description
    while (std::getline(lines, line)) {
        if (line.find("solver:") != std::string::npos)
            continue;  // timing varies: keep files reproducible
        provenance.push_back("certificate:" + line.substr(1));
    }
    if (a.output == "-") {
        write_basis_csv(std::cout, fit.basis);
        return;
    }
    std::ostringstream text, sidecar;
    write_basis_csv(text, fit.basis);
    for (const auto& l : provenance) sidecar << l << "\n";
    if (a.stream) {
        write_text_atomically(a.output, text.str());  // written through to the stream
        return;
    }
    write_text_atomically(basis_provenance_path(a.output), sidecar.str());
    write_text_atomically(a.output, text.str());
}

}  // namespace

int run_basis(const std::vector<std::string>& args, const std::string& command_line) {
    BasisArgs a;
    ArgParser p(
        "basis", "spectex basis [options] -o BASIS.csv",
        "Fits a spectral primary decomposition basis (Mallett & Yuksel 2019): three reflectance\n"
        "spectra S_r, S_g, S_b with RGB(S_k) = e_k under the illuminant and observer, 0 <= S <= 1 "
        "and\n"
        "S_r + S_g + S_b = 1 at every wavelength, minimising the objective. Prints a certificate\n"
        "recomputed from the basis: colour residuals, bound and sum violations, KKT residuals.");
    declare_basis_options(p, a);
    try {
        std::vector<std::string> pos;
        if (p.parse_or_help(args, pos)) return 0;
        check_basis_args(a, pos);
    } catch (const UsageError& e) {
        return usage_error("basis", e.what());
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }
    try {
        fit_and_write(a, command_line);
    } catch (const Error& e) {
        print_error(e.what());
        return 1;
    }
    return 0;
}

}  // namespace spectex
