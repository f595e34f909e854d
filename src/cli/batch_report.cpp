#include "cli/batch_report.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <memory>

#include "base/error.h"
#include "base/run_clock.h"
#include "base/text.h"
#include "cli/commands.h"
#include "io/atomic_file.h"
#include "io/linearizer.h"
#include "io/paths.h"
#include "pipeline/bake_batch.h"
#include "pipeline/batch_files.h"

namespace spectex {

namespace {

std::string seconds_text(double s) {
    char buf[32];
    if (s < 60)
        std::snprintf(buf, sizeof buf, "%.1f s", s);
    else
        std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s) / 60,
                      static_cast<int>(s) % 60);
    return buf;
}

// Names listed per line of the summary; the --json report has every file.
constexpr size_t kListedFiles = 20;

std::string file_list(const std::vector<std::string>& names) {
    std::string out;
    for (size_t i = 0; i < names.size() && i < kListedFiles; ++i) out += (i ? ", " : "") + names[i];
    if (names.size() > kListedFiles)
        out += ", and " + std::to_string(names.size() - kListedFiles) +
               " more (--json lists each file)";
    return out;
}

// One line per colour space and way of choosing it, in input order: which files were read how.
void print_colour_spaces(const BatchPlan& plan, const std::vector<BakeResult>& baked,
                         const std::vector<bool>& was_baked) {
    std::vector<std::pair<std::string, std::vector<std::string>>>
        groups;  // "'space' (how)", inputs
    for (size_t i = 0; i < baked.size(); ++i) {
        if (!was_baked[i]) continue;
        const std::string key = "'" + baked[i].colorspace + "' (" + baked[i].colorspace_how + ")";
        auto it = std::find_if(groups.begin(), groups.end(),
                               [&](const auto& g) { return g.first == key; });
        if (it == groups.end()) it = groups.insert(groups.end(), {key, {}});
        it->second.push_back(plan.files[i].first);
    }
    for (const auto& [key, names] : groups)
        std::cerr << "spectex: " << one_line("colour space " + key + ": " + file_list(names))
                  << "\n";
}

// Once per batch: integer files (display-referred: codes for a screen) read as a scene-linear space
// only because the config's default rule names it are most likely sRGB textures of a studio config
// whose default is ACES2065-1; their only other sign is a count of clamped pixels.
void warn_default_rule_to_linear(const BatchPlan& plan, const BakeSettings& settings,
                                 const std::vector<BakeResult>& baked,
                                 const std::vector<bool>& was_baked) {
    std::vector<std::string> names;
    const BakeResult* first = nullptr;
    for (size_t i = 0; i < baked.size(); ++i)
        if (was_baked[i] && baked[i].integer_to_linear_by_default_rule) {
            if (!first) first = &baked[i];
            names.push_back(plan.files[i].first);
        }
    if (!first) return;
    std::string suggestion;
    try {
        suggestion = srgb_texture_space(settings.data_dir, settings.config);
    } catch (const Error&) {
        // the config was read for every file: it cannot fail here, but a warning never fails a run
    }
    const bool one = names.size() == 1;
    std::string msg =
        "warning: " + std::to_string(names.size()) + " integer (display-referred) file" +
        (one ? " was" : "s were") + " read as '" + first->colorspace +
        "', a scene-linear space, only because the default file rule '" + first->colorspace_rule +
        "' of the OCIO config " + first->config +
        (first->config_from == "shipped" ? " (shipped)" : " (from " + first->config_from + ")") +
        " names it: " + file_list(names) + "; if " +
        (one ? "it is an sRGB texture" : "they are sRGB textures") + ", bake " +
        (one ? "it" : "them") + " with ";
    msg += suggestion.empty()
               ? "--colorspace NAME (the config has no space that decodes as sRGB does)"
               : "--colorspace '" + suggestion + "'";
    std::cerr << "spectex: " << one_line(msg) << "\n";
}

// The command's side of a batch: each file's messages on stderr and its JSON Lines record, the
// progress line, and the summary at the end.
class BatchReport : public BatchListener {
  public:
    explicit BatchReport(const BatchPlan& plan)
        : plan_(plan), t0_(std::chrono::steady_clock::now()) {}

    // The report is an output like the others: written to a temporary file and renamed at the
    // end, so a failed write (a full disk) is a failure and never leaves a short report under its
    // name. False (the error printed) when it cannot be created.
    bool open_json() {
        if (plan_.json.empty() || plan_.json == "-") return true;
        // A stream (standard error, a link into /proc/self/fd) is written through, line by line.
        if ((json_stream_ = stream_fd_of(plan_.json)) >= 0) return true;
        try {
            json_file_ = std::make_unique<AtomicFile>(plan_.json);
        } catch (const Error& e) {
            print_error(std::string(e.what()) + " (--json)");
            return false;
        }
        return true;
    }

    void file_done(const FileRecord& r) override {
        if (plan_.progress && plan_.progress_terminal) std::cerr << "\r\033[K";
        if (r.status == BatchStatus::Failed)
            print_error(name_file(r.input, r.error, "baking"));
        else if (r.status == BatchStatus::Ok)
            print_file_notes(r);  // warnings about the data: --quiet does not silence them
        if (plan_.verbose && r.status == BatchStatus::Ok) print_baked(r);
        if (plan_.verbose && r.status == BatchStatus::Skipped)
            std::cerr << "spectex: " << one_line(quote_path(r.output) + ": " + r.reason) << "\n";
        if (!plan_.json.empty()) write_json(json_record(r));
    }

    void progress(const BatchCounts& counts, const std::vector<JobSlot>& slots) override {
        if (plan_.progress_terminal)
            std::cerr << "\r\033[K" << progress_line(counts, slots) << std::flush;
        else
            std::cerr << utc_stamp() << " " << progress_line(counts, slots) << "\n" << std::flush;
    }

    // The summary, the report committed; the exit status.
    int finish(const BatchOutcome& outcome, const BakeSettings& settings) {
        const BatchCounts& n = outcome.counts;
        if (plan_.progress && plan_.progress_terminal) std::cerr << "\r\033[K";
        const size_t not_attempted = n.total - n.done;
        if (!plan_.quiet && (n.total > 1 || n.failed || n.skipped || !plan_.shard.empty())) {
            const double el =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - process_start())
                    .count();
            std::cerr << "spectex: " << n.ok << " baked, " << n.skipped << " up to date, "
                      << n.failed << " failed";
            if (not_attempted)
                std::cerr << ", " << not_attempted << " not attempted ("
                          << (outcome.signal ? "interrupted by " + signal_name(outcome.signal)
                                             : std::string("--fail-fast"))
                          << ")";
            std::cerr << " of " << n.total << " in " << seconds_text(el);
            if (!plan_.shard.empty())
                std::cerr << " (shard " << plan_.shard << " of " << plan_.listed << " listed file"
                          << (plan_.listed == 1 ? "" : "s") << ")";
            std::cerr << "\n";
            print_colour_spaces(plan_, outcome.baked, outcome.was_baked);
        }
        // A warning about the data: printed under --quiet too.
        warn_default_rule_to_linear(plan_, settings, outcome.baked, outcome.was_baked);
        // Stopped by SIGTERM, SIGINT or SIGHUP: the records above are the files finished; the last
        // one says the run was interrupted, and the report is committed like any other.
        if (outcome.signal && !plan_.json.empty())
            write_json(json_interrupted_record(signal_name(outcome.signal), n.total, n.done,
                                               n.interrupted, settings.settings_hash));
        if (!commit_json()) return 1;
        return n.failed || not_attempted ? 1 : 0;
    }

    // --dry-run: one file's line (stdout, unless the JSON report is written there), its error on
    // stderr as a real run gives it, and its record.
    void file_planned(const DryRunFile& f, const std::string& settings_hash) {
        if (plan_.json != "-") std::cout << dry_run_line(f) << "\n";
        if (f.action == DryRunAction::Fail) print_error(name_file(f.input, f.error, "baking"));
        if (!plan_.json.empty()) write_json(json_dry_run_record(f, settings_hash));
    }

    // --dry-run: the summary, the report committed; 1 when a real run would fail a file.
    int finish_dry_run(size_t bake, size_t skip, size_t fail) {
        std::cout << std::flush;
        if (!plan_.quiet)
            std::cerr << "spectex: dry run: " << bake << " would be baked, " << skip
                      << " skipped as up to date, " << fail << " would fail, of "
                      << plan_.files.size() << "; no pixel was read and nothing was written"
                      << (plan_.json.empty() || plan_.json == "-" ? "" : " but the --json report")
                      << "\n";
        if (!commit_json()) return 1;
        return fail ? 1 : 0;
    }

  private:
    // The report renamed into place; false (the error printed) when it could not be written.
    bool commit_json() {
        if (json_file_ && json_error_.empty()) {
            try {
                json_file_->commit();
            } catch (const Error& e) {
                json_error_ = std::string(e.what()) + " (--json)";
            }
        }
        if (json_error_.empty()) return true;
        print_error(json_error_ + "; the report is incomplete");
        return false;
    }

    // "bake in.png -> out.exr: 64x64, 3 channels, png, colour space 'srgb_tx' (...); --update
    // would bake it: no readable output", "skip ...: up to date: ...", "fail ...: <cause>".
    std::string dry_run_line(const DryRunFile& f) const {
        std::string line = std::string(f.action == DryRunAction::Bake   ? "bake "
                                       : f.action == DryRunAction::Skip ? "skip "
                                                                        : "fail ") +
                           quote_path(f.input) + " -> " + quote_path(f.output) + ": ";
        if (f.action == DryRunAction::Skip) return one_line(line + f.update.reason);
        if (f.action == DryRunAction::Fail) return one_line(line + f.error);
        line += std::to_string(f.width) + "x" + std::to_string(f.height) + ", " +
                std::to_string(f.channels) + " channel" + (f.channels == 1 ? "" : "s") + ", " +
                f.format + ", colour space '" + f.colorspace + "' (" + f.colorspace_how + "); ";
        line += plan_.update          ? "not up to date: "
                : f.update.up_to_date ? "--update would skip it: "
                                      : "--update would bake it: ";
        return one_line(line + f.update.reason);
    }

    void write_json(const std::string& line) {
        if (plan_.json == "-") {
            std::cout << line << std::flush;
            if (!std::cout && json_error_.empty())
                json_error_ = "standard output: cannot write the JSON report";
        } else if (json_stream_ >= 0 && json_error_.empty()) {
            try {
                write_all(json_stream_, line, plan_.json);
            } catch (const Error& e) {
                json_error_ = std::string(e.what()) + " (--json)";
            }
        } else if (json_file_ && json_error_.empty()) {
            try {
                write_all(json_file_->fd(), line, plan_.json);
            } catch (const Error& e) {
                json_error_ = std::string(e.what()) + " (--json)";
            }
        }
    }

    // What the data of a baked file went through (file_warnings, less the default-rule warning,
    // which the batch gives once for all its files).
    static void print_file_notes(const FileRecord& r) {
        const std::string named = one_line(quote_path(r.input));
        for (const auto& w : file_warnings(r.result, false))
            std::cerr << "spectex: " << named << ": " << one_line(w) << "\n";
    }

    // --verbose: what a baked file became, and where its time went.
    static void print_baked(const FileRecord& r) {
        std::cerr << "spectex: " << one_line(quote_path(r.input)) << " -> "
                  << one_line(quote_path(r.output)) << ": " << r.result.pixels << " pixels, "
                  << r.result.bins << " bins, colour space '" << r.result.colorspace << "' ("
                  << r.result.colorspace_how << "), " << r.result.bytes << " bytes, "
                  << seconds_text(r.result.seconds) << "\n";
        const auto& st = r.result.stages;
        char buf[400];
        std::snprintf(buf, sizeof buf,
                      "stages: read %.2f s, colour %.2f s, expand %.2f s (producer thread); "
                      "pack %.2f s, waiting for the encoder %.2f s, for the producer %.2f s, "
                      "finish %.2f s "
                      "(writer thread); compress %.2f CPU-s (%s writer)\n",
                      st.read, st.colour, st.expand, st.pack, st.encoder_wait, st.producer_wait,
                      st.finish, st.compress_cpu, st.writer.c_str());
        std::cerr << "spectex: " << one_line(quote_path(r.input)) << ": " << buf;
    }

    // Files done, and the rows of the files being baked.
    std::string progress_line(const BatchCounts& n, const std::vector<JobSlot>& slots) const {
        const auto now = std::chrono::steady_clock::now();
        const double el = std::chrono::duration<double>(now - t0_).count();
        const size_t done = n.done, total = n.total;
        std::string line = "spectex: [" + std::to_string(done) + "/" + std::to_string(total) +
                           "] " + std::to_string(n.failed) + " failed";
        double file_eta = 0;
        for (const auto& sl : slots) {
            if (sl.input.empty()) continue;
            const long d = sl.rows.rows_done.load(), t = sl.rows.rows_total.load();
            if (t <= 0) continue;
            char buf[96];
            std::snprintf(buf, sizeof buf, ": rows %ld/%ld (%d%%)", d, t,
                          static_cast<int>(100.0 * d / t));
            line += "; " + one_line(file_name_of(sl.input)) + buf;
            const double fe = std::chrono::duration<double>(now - sl.start).count();
            if (d > 0)
                file_eta =
                    std::max(file_eta, fe / static_cast<double>(d) * static_cast<double>(t - d));
        }
        double eta =
            done ? el / static_cast<double>(done) * static_cast<double>(total - done) : file_eta;
        if (total == 1) eta = file_eta;
        if (done || file_eta > 0) line += ", ETA " + seconds_text(eta);
        return line;
    }

    const BatchPlan& plan_;
    const std::chrono::steady_clock::time_point t0_;
    std::unique_ptr<AtomicFile> json_file_;
    int json_stream_ = -1;
    std::string json_error_;
};

}  // namespace

int run_dry_run(const BatchPlan& plan, const BakeSettings& settings) {
    BatchReport report(plan);
    if (!report.open_json()) return 1;
    size_t count[3] = {0, 0, 0};
    for (size_t i = 0; i < plan.files.size(); ++i) {
        const DryRunFile f = dry_run_file(plan, i, settings);
        ++count[static_cast<int>(f.action)];
        report.file_planned(f, settings.settings_hash);
    }
    return report.finish_dry_run(count[0], count[1], count[2]);
}

std::string utc_stamp() {
    const std::time_t now = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&now, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

int run_batch(const BatchPlan& plan, const BakeSettings& settings) {
    BatchReport report(plan);
    if (!report.open_json()) return 1;
    // From the first file on, SIGTERM, SIGINT and SIGHUP stop the batch instead of ending the
    // process: the files finished keep their records, the report is committed, and main ends the
    // process by the signal after its last line (io/atomic_file.h).
    defer_termination_requests();
    const BatchOutcome outcome = bake_batch(plan, settings, report);
    return report.finish(outcome, settings);
}

}  // namespace spectex
