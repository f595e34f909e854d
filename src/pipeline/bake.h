#pragma once
// The streaming bake of one texture: read (OIIO) -> linearise (OCIO) -> policies -> expand ->
// write (OpenEXR), a strip of rows at a time, into an atomic output file.
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "io/alpha_kind.h"
#include "io/spectral_exr_writer.h"
#include "pipeline/pixel_policy.h"
#include "spectral/spectral_method.h"
#include "spectral/wavelength_grid.h"

namespace spectex {

// What the command line says of every file's output, taken as given: colour, layout, policies.
// The set-up (pipeline/bake_request) adds what is resolved or built from the rest.
struct BakeOptions {
    std::string colorspace;  // --colorspace ("" = metadata, then file rules)
    std::string config;      // --config ("" = $OCIO, then the shipped config)
    SampleType type = SampleType::Half;
    ExrCompression compression = ExrCompression::parse(ExrCompression::kDefault);
    // Deflate level of zip/zips (1 fastest .. 12 smallest); 0: by the file's size, as the default
    // bake chooses it (zip_level_for).
    int zip_level = 4;
    bool preview = false;
    AlphaKind alpha = AlphaKind::Associated;  // --alpha: what a source's A means (never None)
    RangePolicy range = RangePolicy::Clamp;
    NanPolicy nan = NanPolicy::Replace;
    uint64_t max_pixels = 268435456;  // 16384 x 16384
    // The options given that make each file what it is, shell-quoted, each after a space: the
    // options of the command line each output records (spectex:commandLine, with its own input and
    // output: file_command_line below), never the batch's list of files.
    std::string file_options;
    int tile_width = 0, tile_height = 0;  // tiled output when > 0
    bool mipmap = false;          // MIP-mapped (tiled) output, levels filtered on linear RGB
    bool colour_rounding = true;  // half: round bins to keep the integrated colour closest
    // --wrap/--swrap/--twrap: the "wrapmodes" attribute, "s,t" (e.g. "periodic,clamp"); "" when
    // none was given (a tiled output then records maketx's default, black,black).
    std::string wrapmodes;
};

// Everything a file of a batch is baked with: the options, and what the set-up resolved and built
// from the request once per batch (pipeline/bake_request: prepare_bake). Const once made.
struct BakeSettings : BakeOptions {
    std::string data_dir;
    std::shared_ptr<const SpectralMethod> method;  // RGB -> spectrum, already on the output grid
    // The conditions the method is exact for (a given table's own: mallett2019 is cie1931-2, D65).
    std::string observer = "cie1931-2";
    std::string illuminant = "D65";
    WavelengthGrid grid;
    // Half's colour-aware rounding: the sRGB weights of each bin (bins x 3) under the observer and
    // illuminant, computed once for the batch; empty for float or nearest rounding.
    std::vector<float> half_rgb_weight;
    // The linear sRGB of a unit spectrum at each bin under the observer and illuminant (3 x bins,
    // row-major): what a renderer integrates the file's spectra with to rebuild them from RGB
    // (spectex:rebuildToRgb).
    std::vector<double> bin_rgb;
    std::string settings_hash;         // recorded as spectex:settingsHash (for --update)
    std::string legacy_settings_hash;  // --update of outputs that record no colour transform
    // What builds `method` (options and the tables' values), hashed into settings_hash instead of
    // the built method's checksum, so that the hash is known before the method is built.
    std::string method_recipe;
    int threads = 1;  // OpenEXR compression threads for this file (the batch's, bake_batch)
    // --wavelengths auto: what chose the grid, recorded as spectex:plan* and hashed.
    struct Plan {
        std::string lights, max_de, reconstruction, range, worst_de;  // empty: the grid was given
        bool nonuniform = false;  // --nonuniform: non-uniform grids were candidates too
    } plan;
    // --precision auto (half only): the mantissa bits each bin keeps, chosen once per batch
    // (spectral/precision.h), recorded as spectex:precision* and hashed. Empty bits: full half.
    struct Precision {
        std::string recipe;  // what chooses the bits (budget, lights and their tables), hashed
        std::vector<int> bits;
        // worst_code: per light, the 8-bit sRGB code of worst_de ("D65 #rrggbb, A #rrggbb").
        std::string max_de, lights, worst_de, worst_code, sample;
    } precision;
};

struct BakeResult {
    std::string input, output;
    std::string colorspace, colorspace_how;
    std::string
        colorspace_rule;  // the config's file rule that chose it ("" when it was not a rule)
    std::string config, config_from;  // the OCIO config used, and "--config", "$OCIO" or "shipped"
    // An integer (display-referred) input read as a scene-linear space only because the config's
    // default file rule names that space: most likely an sRGB texture the config knows nothing of.
    bool integer_to_linear_by_default_rule = false;
    uint64_t pixels = 0;
    int bins = 0;
    uint64_t bytes = 0;
    uint64_t clamped_pixels = 0;   // pixels with a linear component moved into [0, 1]
    float clamped_excursion = 0;   // the farthest outside [0, 1] such a component was
    uint64_t replaced_pixels = 0;  // pixels with a NaN/Inf component replaced
    double seconds = 0;
    // Where the time went (seconds). The producer thread reads (decode), colours (linearise, NaN
    // and range policies, premultiply) and expands; the writer thread packs rows into chunks and
    // waits — for a free chunk buffer (the encoder is the bottleneck: good) or for the producer
    // (the producer is: `producer_wait`); the workers compress (CPU seconds summed).
    struct Stages {
        double read = 0, colour = 0, expand = 0;
        double pack = 0, encoder_wait = 0, producer_wait = 0, compress_cpu = 0, finish = 0;
        std::string writer;  // "core" or "imf"
    } stages;
    std::vector<std::string> notes;  // e.g. "input has 3 MIP levels: the first was used"
};

// Rows of one bake written so far, for a progress display on another thread (MIP levels count their
// own rows: rows_total is the sum over levels). Set once the input's header is read.
struct BakeProgress {
    std::atomic<long> rows_done{0}, rows_total{0};
};

// Throws Error ("<file>: <cause>") on failure; the output then does not exist under its name.
BakeResult bake_file(const std::string& input, const std::string& output, const BakeSettings& s,
                     BakeProgress* progress = nullptr);

// Rows per strip: about 32 MB of spectral samples (row_bytes each). The C++ writer and tiled files
// take whole chunks (lines_per_chunk rows, rounded up to one); the core writer takes any rows, so
// at high bin counts a strip may be less than a chunk. At most `height`.
int strip_rows(size_t row_bytes, int lines_per_chunk, bool whole_chunks, int height);

// The command that rebuilds one output of a batch alone, shell-quoted as `quote_path` quotes:
// "spectex bake <input> -o <output><options>" (options: BakeSettings::file_options). An input
// that starts with '-' goes last, after "--", where it cannot be taken for an option. Its size
// depends on this file's names and the options, never on how many files the batch had.
std::string file_command_line(const std::string& input, const std::string& output,
                              const std::string& options);

}  // namespace spectex
