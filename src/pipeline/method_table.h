#pragma once
// The upsampling methods, one row each: what a method is called, what it guarantees (exact under
// the illuminant it was built for, linear in RGB, defined outside [0, 1]), which options belong to
// it, what its table costs and how it is built. Every command asks the table instead of spelling
// method names, so a new method is its file under spectral/ and one row here (docs/ARCHITECTURE.md
// lists what else it may touch). The built methods are memoised per process, so that a batch or a
// plan builds each once.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "pipeline/basis_cache.h"
#include "pipeline/cached_answer.h"
#include "spectral/spectral_method.h"

namespace spectex {

enum class MethodKind { Basis, Lattice, JakobHanika };

// What builds a method: its kind, the conditions it is exact for (fit: grid, observer, illuminant,
// primaries, data dir; the basis also reads the objective and allow_infeasible) and the options of
// each kind (read only by the kind they belong to).
struct MethodSpec {
    MethodKind kind = MethodKind::Basis;
    FitSpec fit;
    int lattice_size = 9;
    std::string vertex_prior = "jakob-hanika";
    double blend = 100;  // vertex prior "blend": weight of the smoothness term
    int jh_resolution = 33;

    const std::string& name() const;  // "basis", "lattice", "jakob-hanika"
    // The method without its conditions: "lattice 9, jakob-hanika prior", "jakob-hanika table
    // 33", "basis (fitted, smooth)".
    std::string head() const;
    // head() and the conditions: "lattice 9, jakob-hanika prior, srgb primaries, cie1931-2, D65,
    // 380:780:5".
    std::string describe() const;
};

struct MethodResult {
    std::shared_ptr<const SpectralMethod> method;
    double build_seconds = 0;
    // Said once to the user when the method is built: a basis fitted with --allow-infeasible
    // where no exact basis exists (how far it misses the primaries). Empty when nothing is wrong.
    std::string warning;
    // What became of the method's entry in the cache (make_method with a folder): hit, refused,
    // the store's warning; folder "" when the method was not looked up there.
    CacheReport cache;
};

struct MethodRow {
    MethodKind kind;
    std::string name;
    // One sentence for --method's help.
    std::string help;
    // Exact under the illuminant it was built for: every 8-bit colour re-encodes to its code
    // (verify gates the colour error of such files).
    bool exact;
    // spectrum(a·c1 + b·c2) = a·spectrum(c1) + b·spectrum(c2): filtering RGB before expanding
    // keeps the spectrum, and plan measures the whole cube through the three primaries' spectra.
    bool linear;
    // Defined for linear RGB outside [0, 1] (--out-of-range keep); the others clamp.
    bool takes_out_of_range;
    // The options that belong to this method alone (a usage error with another method).
    std::vector<std::string> options;
    // The option that sizes its table, what the table's nodes are ("vertices"), and the nodes per
    // axis it asks for (0: no table).
    std::string table_option, table_nodes;
    int (*table_axis)(const MethodSpec&);
    std::string (*head)(const MethodSpec&);
    // The words that identify what builds it, hashed into a bake's settings before it is built
    // (the tables' values are hashed beside them): a change of any option of the method changes
    // them. Never reworded for an existing method: --update compares them with old files.
    std::string (*recipe)(const MethodSpec&);
    MethodResult (*build)(const MethodSpec&);
    // A table worth keeping between runs (make_method with a cache folder): its numbers, and the
    // method made from them again, which throws Error unless they are a table build could have made
    // for the spec (a refused entry is built again). Null for a method that is quick to make.
    std::vector<double> (*stored_table)(const SpectralMethod&);
    MethodResult (*from_stored_table)(const MethodSpec&, std::vector<double>);
};

// Every method, in the order --help lists them (the default first).
const std::vector<MethodRow>& method_table();
// " data <checksum>" of the measured vertex prior's table for a lattice that uses it, else "":
// part of the method's recipe and of every cache key that names the prior.
std::string vertex_prior_data(const MethodSpec& spec);
const MethodRow& method_row(MethodKind kind);
// The row called `name`, or null (a file recorded by a later spectex may name a method this one
// does not know).
const MethodRow* find_method(const std::string& name);
// Whether a file baked with the method called `name` is exact under its illuminant; a name this
// spectex does not know is taken as exact, so its colour is gated rather than waved through.
bool method_is_exact(const std::string& name);
// "basis, lattice, jakob-hanika" (with sep ", "), "basis|lattice|jakob-hanika" (with "|").
std::string method_names(const std::string& sep);
// The row of an option that belongs to one method ("--lattice-size" -> lattice), or null.
const MethodRow* method_of_option(const std::string& option);

// Builds (or returns the process' memo of) the method. Throws Error (with the cause: a vertex with
// no exact bounded spectrum on this grid, an infeasible basis, ...), and LimitError when the table
// is over kMethodTableLimit. Thread-safe; builds of different methods run at the same time.
// With a cache folder (io/data_dir: cache_folder; "" = none), a method whose row keeps its table
// (stored_table) and whose table is at most kMethodCacheSamples is read from the entry
// method-<hash> there, or built and stored (pipeline/cached_answer.h): every process of a farm,
// a batch of shell calls or the test suite builds the default lattice once per settings, not once
// per run. The answer is the build's, bit for bit (its checksum and every spectrum).
MethodResult make_method(const MethodSpec& spec, const std::string& cache_folder = "");

// The cache format of a method's table; a change of what an entry holds changes it.
constexpr int kMethodCacheFormat = 1;
// Tables larger than this are built every time (their entries would be tens of MB of text):
// 2^21 samples, 35 times the default lattice's 59,049 (9^3 vertices x 81 bins).
constexpr uint64_t kMethodCacheSamples = uint64_t(1) << 21;
// What the built table depends on, hashed: this build of spectex, the format, the method's recipe
// and description, the blend weight, the observer's and illuminant's tables by value and the
// grid's wavelengths and weights. "method-<32 hex digits>".
std::string method_cache_key(const MethodSpec& spec);

// What building the method costs: the spectral samples its table holds and computes, n^3 x bins
// for the lattice (a spectrum per vertex, each a QP over the bins) and res^3 x bins for the
// Jakob-Hanika table (each node fitted by integrating its sigmoid over the bins); 0 for the basis.
uint64_t method_table_samples(const MethodSpec& spec, uint64_t bins);
// The most method_table_samples() may be: 2^27 (134,217,728; 512 MiB as float). The largest table
// the options allow on the finest grid a renderer reads (1 nm over 360:830, 471 bins) fits it:
// --lattice-size 65 (65^3 x 471 = 129 million) and --jh-resolution 64 (123 million). Measured:
// lattice 65 at 801 bins (380:780:0.5, 220 million) took 54 s and 3.58 GB for a 16x16 image;
// past the limit the grid is finer than 1 nm or the lattice larger than anything baked.
constexpr uint64_t kMethodTableLimit = uint64_t(1) << 27;
// Throws LimitError ("--lattice-size: ..." or "--jh-resolution: ...", with the figure and the
// limit) when method_table_samples(spec, bins) is over kMethodTableLimit; `what` says what the
// bins are ("801 bins", "3416 bins of the candidates and the reference").
void check_method_cost(const MethodSpec& spec, uint64_t bins, const std::string& what);

}  // namespace spectex
