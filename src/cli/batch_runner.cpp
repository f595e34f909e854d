#include "cli/batch_runner.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "cli/commands.h"
#include "io/atomic_file.h"
#include "io/file_identity.h"
#include "io/linearizer.h"
#include "io/paths.h"
#include "pipeline/batch.h"
#include "spectral/error.h"
#include "spectral/text.h"

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

// "2026-12-02T03:59:01Z": the prefix of a progress line in a log.
std::string utc_stamp() {
    const std::time_t now = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&now, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

// What one job is baking, for the progress line.
struct JobSlot {
    std::string input;  // "" when idle (guarded by the batch's io mutex)
    std::chrono::steady_clock::time_point start;
    BakeProgress rows;
};

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

}  // namespace

int run_batch(const BatchPlan& plan, const BakeSettings& settings) {
    const auto t0 = std::chrono::steady_clock::now();
    const size_t total = plan.files.size();
    std::mutex io;
    // The report is an output like the others: written to a temporary file and renamed at the end,
    // so a failed write (a full disk) is a failure and never leaves a short report under its name.
    std::unique_ptr<AtomicFile> json_file;
    std::string json_error;
    if (!plan.json.empty() && plan.json != "-") {
        try {
            json_file = std::make_unique<AtomicFile>(plan.json);
        } catch (const Error& e) {
            print_error(std::string(e.what()) + " (--json)");
            return 1;
        }
    }
    auto write_json = [&](const std::string& line) {
        if (plan.json == "-") {
            std::cout << line << std::flush;
            if (!std::cout && json_error.empty())
                json_error = "standard output: cannot write the JSON report";
        } else if (json_file && json_error.empty()) {
            try {
                write_all(json_file->fd(), line, plan.json);
            } catch (const Error& e) {
                json_error = std::string(e.what()) + " (--json)";
            }
        }
    };

    // Two inputs must never race for one output inside a batch: outputs are compared by where
    // they land (folders resolved, links followed), not by how they are spelt.
    std::map<std::string, size_t> first_by_key;
    std::map<std::pair<dev_t, ino_t>, size_t> first_by_id;
    std::vector<std::string> clash(total);
    for (size_t i = 0; i < total; ++i) {
        const OutputTarget t = output_target(plan.files[i].second);
        size_t first = i;
        if (auto [it, fresh] = first_by_key.emplace(t.key, i); !fresh) first = it->second;
        if (t.existing)
            if (auto [it, fresh] =
                    first_by_id.emplace(std::make_pair(t.existing->dev, t.existing->ino), i);
                !fresh)
                first = std::min(first, it->second);
        if (first != i)
            clash[i] = plan.files[i].first + ": its output " + plan.files[i].second +
                       " is also the output of " + plan.files[first].first + " (as " +
                       plan.files[first].second + "); not baked twice";
    }

    std::atomic<size_t> next{0};
    std::atomic<bool> stop{false};
    size_t done = 0, ok = 0, skipped = 0, failed = 0;
    // Per input, in input order: its colour space and how it was chosen (baked files only), and
    // whether it is an integer file read as scene-linear through the default rule, for the summary.
    std::vector<BakeResult> baked(total);
    std::vector<bool> was_baked(total, false);

    const int jobs = std::max(1, std::min<int>(plan.jobs, static_cast<int>(total)));
    std::vector<JobSlot> slots(static_cast<size_t>(jobs));
    // The progress line (io held): files done, and the rows of the files being baked.
    auto progress_line = [&]() {
        const auto now = std::chrono::steady_clock::now();
        const double el = std::chrono::duration<double>(now - t0).count();
        std::string line = "spectex: [" + std::to_string(done) + "/" + std::to_string(total) +
                           "] " + std::to_string(failed) + " failed";
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
    };
    auto show_progress = [&]() {
        if (plan.progress_terminal)
            std::cerr << "\r\033[K" << progress_line() << std::flush;
        else
            std::cerr << utc_stamp() << " " << progress_line() << "\n" << std::flush;
    };

    auto report = [&](const FileRecord& r) {
        std::lock_guard<std::mutex> lock(io);
        if (plan.progress && plan.progress_terminal) std::cerr << "\r\033[K";
        if (r.status == BatchStatus::Failed) {
            print_error(name_file(r.input, r.error));
        } else if (!plan.quiet) {
            const std::string named = one_line(quote_path(r.input));
            for (const auto& n : r.result.notes)
                std::cerr << "spectex: " << named << ": note: " << one_line(n) << "\n";
            if (r.result.clamped_pixels)
                std::cerr << "spectex: " << named << ": " << r.result.clamped_pixels
                          << " pixels had linear values outside [0, 1] and were clamped\n";
            if (r.result.replaced_pixels)
                std::cerr << "spectex: " << named << ": " << r.result.replaced_pixels
                          << " pixels had NaN/Inf values replaced with 0\n";
        }
        if (plan.verbose && r.status == BatchStatus::Ok)
            std::cerr << "spectex: " << one_line(quote_path(r.input)) << " -> "
                      << one_line(quote_path(r.output)) << ": " << r.result.pixels << " pixels, "
                      << r.result.bins << " bins, colour space '" << r.result.colorspace << "' ("
                      << r.result.colorspace_how << "), " << r.result.bytes << " bytes, "
                      << seconds_text(r.result.seconds) << "\n";
        if (plan.verbose && r.status == BatchStatus::Ok) {
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
        if (plan.verbose && r.status == BatchStatus::Skipped)
            std::cerr << "spectex: " << one_line(quote_path(r.output) + ": " + r.reason) << "\n";
        if (!plan.json.empty()) write_json(json_record(r));
        ++done;
        ok += r.status == BatchStatus::Ok;
        skipped += r.status == BatchStatus::Skipped;
        failed += r.status == BatchStatus::Failed;
        if (plan.progress) show_progress();
    };

    auto worker = [&](size_t job) {
        JobSlot& slot = slots[job];
        for (;;) {
            if (stop.load()) return;
            size_t i = next.fetch_add(1);
            if (i >= total) return;
            FileRecord r;
            r.input = plan.files[i].first;
            r.output = plan.files[i].second;
            r.settings_hash = settings.settings_hash;
            auto start = std::chrono::steady_clock::now();
            try {
                if (!clash[i].empty()) throw Error(clash[i]);
                UpdateCheck check;
                if (plan.update)
                    check = i < plan.prechecked.size()
                                ? plan.prechecked[i]
                                : check_update(r.input, r.output, settings.settings_hash);
                if (check.up_to_date) {
                    r.status = BatchStatus::Skipped;
                    r.reason = check.reason;
                } else {
                    if (plan.make_folders) {
                        const size_t slash = r.output.find_last_of('/');
                        if (slash != std::string::npos && slash > 0)
                            make_folders(r.output.substr(0, slash));
                    }
                    {
                        std::lock_guard<std::mutex> lock(io);
                        slot.input = r.input;
                        slot.start = std::chrono::steady_clock::now();
                        slot.rows.rows_done = 0;
                        slot.rows.rows_total = 0;
                    }
                    r.result = bake_file(r.input, r.output, settings, &slot.rows);
                    r.status = BatchStatus::Ok;
                }
            } catch (const Error& e) {
                r.status = BatchStatus::Failed;
                r.error = e.what();
            } catch (const std::exception& e) {
                r.status = BatchStatus::Failed;
                r.error = r.input + ": " + e.what();
            }
            {
                std::lock_guard<std::mutex> lock(io);
                slot.input.clear();
            }
            r.result.seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            if (r.status == BatchStatus::Failed && plan.fail_fast) stop.store(true);
            report(r);
            if (r.status == BatchStatus::Ok) {
                std::lock_guard<std::mutex> lock(io);
                baked[i] = r.result;
                was_baked[i] = true;
            }
        }
    };
    // Progress within files: a few times a second on a terminal, every 10 s in a log.
    std::mutex tick_mutex;
    std::condition_variable tick_cv;
    bool finished = false;
    std::thread ticker;
    if (plan.progress)
        ticker = std::thread([&] {
            // A log's cadence: SPECTEX_PROGRESS_SECONDS (default 10).
            double log_seconds = 10;
            if (const char* e = std::getenv("SPECTEX_PROGRESS_SECONDS")) {
                double v = 0;
                if (parse_finite(e, &v) && v >= 0.01 && v <= 86400) log_seconds = v;
            }
            const auto period =
                plan.progress_terminal
                    ? std::chrono::milliseconds(250)
                    : std::chrono::milliseconds(static_cast<long>(log_seconds * 1000));
            std::unique_lock<std::mutex> lock(tick_mutex);
            while (!tick_cv.wait_for(lock, period, [&] { return finished; })) {
                std::lock_guard<std::mutex> io_lock(io);
                bool busy = false;
                for (const auto& sl : slots)
                    busy = busy || (!sl.input.empty() && sl.rows.rows_total.load() > 0);
                if (busy) show_progress();
            }
        });
    std::vector<std::thread> pool;
    for (int j = 1; j < jobs; ++j) pool.emplace_back(worker, static_cast<size_t>(j));
    worker(0);
    for (auto& t : pool) t.join();
    if (ticker.joinable()) {
        {
            std::lock_guard<std::mutex> lock(tick_mutex);
            finished = true;
        }
        tick_cv.notify_all();
        ticker.join();
    }

    if (plan.progress && plan.progress_terminal) std::cerr << "\r\033[K";
    const size_t not_attempted = total - done;
    if (!plan.quiet && (total > 1 || failed || skipped)) {
        double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::cerr << "spectex: " << ok << " baked, " << skipped << " up to date, " << failed
                  << " failed";
        if (not_attempted) std::cerr << ", " << not_attempted << " not attempted (--fail-fast)";
        std::cerr << " of " << total << " in " << seconds_text(el) << "\n";
        print_colour_spaces(plan, baked, was_baked);
    }
    if (!plan.quiet) warn_default_rule_to_linear(plan, settings, baked, was_baked);
    if (json_file && json_error.empty()) {
        try {
            json_file->commit();
        } catch (const Error& e) {
            json_error = std::string(e.what()) + " (--json)";
        }
    }
    if (!json_error.empty()) {
        print_error(json_error + "; the report is incomplete");
        return 1;
    }
    return failed || not_attempted ? 1 : 0;
}

}  // namespace spectex
