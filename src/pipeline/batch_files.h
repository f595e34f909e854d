#pragma once
// Batches of files: input expansion (UDIM tiles, lists), output naming, sharding, the settings
// hash used by --update, and one JSON Lines record per file.
#include <cstdint>
#include <string>
#include <vector>

#include "pipeline/bake.h"
#include "pipeline/update_check.h"

namespace spectex {

// Expands <UDIM> (1001..) and <UVTILE> (u1_v1..) in a path to the existing files, byte-sorted; a
// path without tokens is returned as is (whether or not it exists: the bake reports that).
std::vector<std::string> expand_tiles(const std::string& path);

// Reads one path per line ('-' = stdin); blank lines and lines starting with '#' are skipped.
std::vector<std::string> read_list(const std::string& file);

// Output name for an input: a template with {dir}, {reldir}, {stem}, {ext} (e.g.
// "{dir}/{stem}.exr"), or "<output_dir>/<stem>.exr" when output_dir is given
// ("<output_dir>/{reldir}/<stem>.exr" with a base_dir: the tree below base_dir mirrored). {reldir}
// is the input's folder relative to base_dir
// ("." for base_dir itself). Throws Error when the input's name would make a path component "", "."
// or ".." that the template does not have, when an input lies outside base_dir, when {reldir} has
// no base_dir, or when {dir} under output_dir would climb out of it ("..").
std::string output_for(const std::string& input, const std::string& templ,
                       const std::string& output_dir, const std::string& base_dir = "");
// The input's folder relative to base_dir, both made absolute and normalised lexically (links are
// not followed: the mirror is of names). Throws Error naming both when the input is not below it.
std::string relative_folder(const std::string& input, const std::string& base_dir);
const std::vector<std::string>& template_tokens();  // {dir}, {reldir}, {stem}, {ext}
bool has_template_tokens(const std::string& s);
// The first "{...}" in s that is not a template token ("" when none).
std::string unknown_template_token(const std::string& s);

// --shard K/N: the inputs i (0-based in the sorted list) with i mod N == K-1.
struct Shard {
    int k = 1, n = 1;
    static Shard parse(const std::string& spec);  // throws Error
};
// Any list by position: the inputs, or (input, output) pairs named before the shard is taken.
template <typename T>
std::vector<T> select_shard(const std::vector<T>& sorted_inputs, Shard s) {
    std::vector<T> out;
    for (size_t i = 0; i < sorted_inputs.size(); ++i)
        if (static_cast<int>(i % static_cast<size_t>(s.n)) == s.k - 1)
            out.push_back(sorted_inputs[i]);
    return out;
}

// What became of one file of a batch; to_string gives the word the report writes.
enum class BatchStatus { Ok, Skipped, Failed };
const char* to_string(BatchStatus s);  // "ok", "skipped", "failed"

struct FileRecord {
    std::string input, output;
    BatchStatus status = BatchStatus::Failed;
    std::string error;
    BakeResult result;
    std::string settings_hash;
    std::string reason;  // skipped: why (check_update)
};
// Version 2: a name (or other text) that is not UTF-8 is written with U+FFFD for its stray bytes
// plus a "<field>_bytes_hex" field with its exact bytes (json_text.h); version 1 wrote them as
// \udcXX, which strict JSON parsers refuse.
constexpr int kJsonSchemaVersion = 2;
// The record of one file: one line of JSON, with its line break.
// What a baked file's data went through that its user must hear of, even under --quiet (which
// silences progress and information, never these): the input's notes (a MIP level or subimage
// left out), pixels clamped or replaced, and an integer file read as scene-linear only because the
// OCIO config's default rule says so (left out with default_rule = false: a batch gives that one
// once for all its files). One sentence each, without the file's name.
std::vector<std::string> file_warnings(const BakeResult& r, bool default_rule = true);

std::string json_record(const FileRecord& r);

// The last record of a batch stopped by a termination request (SIGTERM, SIGINT): no input or
// output, "status": "interrupted", "signal": its name, and how many of the shard's files were
// finished (recorded above it), stopped inside their bake, and not started.
std::string json_interrupted_record(const std::string& signal, size_t files, size_t finished,
                                    size_t stopped, const std::string& settings_hash);

// bake --dry-run: what a real run would do with one file, found from headers only.
enum class DryRunAction { Bake, Skip, Fail };
const char* to_string(DryRunAction a);  // "would_bake", "would_skip", "would_fail"

struct DryRunFile {
    std::string input, output;
    DryRunAction action = DryRunAction::Bake;
    UpdateCheck update;  // what --update finds, whether or not it was given
    std::string error;   // Fail: why a real run would fail this file
    // From the input's header (a file that would be baked): size, channels, format, and the colour
    // space a real run would read it as, and how that was chosen.
    int width = 0, height = 0, channels = 0;
    std::string format, colorspace, colorspace_how;
};
// The record of one file of a dry run (the same schema_version, "dry_run": true, a status of
// to_string(DryRunAction)): one line of JSON, with its line break.
std::string json_dry_run_record(const DryRunFile& f, const std::string& settings_hash);

}  // namespace spectex
