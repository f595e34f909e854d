#include "pipeline/bake_batch.h"

#include <OpenEXR/ImfThreading.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "base/error.h"
#include "base/task_pool.h"
#include "base/text.h"
#include "io/atomic_file.h"
#include "io/file_identity.h"
#include "io/image_library.h"
#include "io/image_source.h"
#include "io/linearizer.h"
#include "io/paths.h"

namespace spectex {

std::vector<std::string> output_clashes(
    const std::vector<std::pair<std::string, std::string>>& files) {
    const size_t total = files.size();
    std::map<std::string, size_t> first_by_key;
    std::map<std::pair<dev_t, ino_t>, size_t> first_by_id;
    std::vector<std::string> clash(total);
    for (size_t i = 0; i < total; ++i) {
        const OutputTarget t = output_target(files[i].second);
        size_t first = i;
        if (auto [it, fresh] = first_by_key.emplace(t.key, i); !fresh) first = it->second;
        if (t.existing)
            if (auto [it, fresh] =
                    first_by_id.emplace(std::make_pair(t.existing->dev, t.existing->ino), i);
                !fresh)
                first = std::min(first, it->second);
        if (first == i) continue;
        // One file named twice (a.png, ./a.png): not two inputs to tell apart.
        const std::optional<FileId> a = file_id(files[i].first);
        const bool same = a && a == file_id(files[first].first);
        clash[i] = files[i].first + ": its output " + files[i].second + " is also the output of " +
                   files[first].first + " (as " + files[first].second + ")" +
                   (same ? ": the same file, given twice; list it once" : "");
    }
    return clash;
}

std::chrono::milliseconds progress_period(bool terminal) {
    double log_seconds = 10;
    if (const char* e = std::getenv("SPECTEX_PROGRESS_SECONDS")) {
        double v = 0;
        if (parse_finite(e, &v) && v >= 0.01 && v <= 86400) log_seconds = v;
    }
    return terminal ? std::chrono::milliseconds(250)
                    : std::chrono::milliseconds(static_cast<long>(log_seconds * 1000));
}

namespace {

// The batch's state shared by its workers and its progress ticker.
// The batch's settings with its threads per file (size_batch_threads' plan.threads).
BakeSettings with_file_threads(const BakeSettings& s, int threads) {
    BakeSettings out = s;
    out.threads = threads;
    return out;
}

struct BatchRun {
    const BatchPlan& plan;
    const BakeSettings settings;
    BatchListener& listener;
    const size_t total;
    std::vector<std::string> clash;
    std::mutex io;
    std::atomic<size_t> next{0};
    std::atomic<bool> stop{false};
    BatchOutcome outcome;
    std::vector<JobSlot> slots;

    BatchRun(const BatchPlan& p, const BakeSettings& s, BatchListener& l, size_t jobs)
        : plan(p),
          settings(with_file_threads(s, p.threads)),
          listener(l),
          total(p.files.size()),
          clash(output_clashes(p.files)),
          slots(jobs) {
        outcome.counts.total = total;
        outcome.baked.resize(total);
        outcome.was_baked.assign(total, false);
    }

    // The listener told, the counts kept (io held).
    void report(const FileRecord& r) {
        std::lock_guard<std::mutex> lock(io);
        listener.file_done(r);
        BatchCounts& n = outcome.counts;
        ++n.done;
        n.ok += r.status == BatchStatus::Ok;
        n.skipped += r.status == BatchStatus::Skipped;
        n.failed += r.status == BatchStatus::Failed;
        if (plan.progress) listener.progress(n, slots);
    }

    // File i: skipped when up to date, else its folders made and baked in `slot`.
    void bake_one(size_t i, JobSlot& slot, FileRecord& r) {
        if (!clash[i].empty()) throw Error(clash[i] + "; not baked twice");
        UpdateCheck check;
        if (plan.update)
            check = i < plan.prechecked.size() ? plan.prechecked[i]
                                               : check_update(r.input, r.output, settings);
        if (check.up_to_date) {
            r.status = BatchStatus::Skipped;
            r.reason = check.reason;
            return;
        }
        if (plan.make_folders) {
            const std::string folder = folder_of(r.output);
            if (folder != "." && folder != "/") make_folders(folder);
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

    void worker(size_t job) {
        JobSlot& slot = slots[job];
        for (;;) {
            if (stop.load() || termination_requested()) return;
            size_t i = next.fetch_add(1);
            if (i >= total) return;
            FileRecord r;
            r.input = plan.files[i].first;
            r.output = plan.files[i].second;
            r.settings_hash = settings.settings_hash;
            auto start = std::chrono::steady_clock::now();
            try {
                bake_one(i, slot, r);
            } catch (const BakeInterrupted&) {
                // Neither finished nor failed: no record; its temporary file is already removed.
                std::lock_guard<std::mutex> lock(io);
                slot.input.clear();
                ++outcome.counts.interrupted;
                return;
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
                outcome.baked[i] = r.result;
                outcome.was_baked[i] = true;
            }
        }
    }
};

}  // namespace

namespace {

// Why a real run could not create `output` (its folder missing, not a folder, or not writable;
// with make_folders, the nearest folder that exists above it), or "".
std::string output_folder_problem(const std::string& output, bool make_folders) {
    std::string landing;
    try {
        landing = output_landing(output);  // a link to a file lands in the target's folder
    } catch (const Error& e) {
        return e.what();
    }
    std::string folder = folder_of(landing);
    struct stat st;
    bool created = false;
    while (::stat(folder.c_str(), &st) != 0) {
        if (!make_folders) return folder + ": the output's folder does not exist";
        const std::string up = folder_of(folder);
        if (up == folder) return "";
        folder = up;
        created = true;
    }
    const std::string doing = created ? ": cannot create the output folder: " : ": ";
    if (!S_ISDIR(st.st_mode)) return folder + doing + "something that is not a folder is there";
    if (::access(folder.c_str(), W_OK | X_OK) != 0)
        return folder + doing + "cannot write in it: " + std::strerror(errno);
    return "";
}

}  // namespace

DryRunFile dry_run_file(const BatchPlan& plan, size_t i, const BakeSettings& settings) {
    DryRunFile f;
    f.input = plan.files[i].first;
    f.output = plan.files[i].second;
    f.update = check_update(f.input, f.output, settings);
    if (plan.update && f.update.up_to_date) {
        f.action = DryRunAction::Skip;
        return f;
    }
    try {
        if (std::string why = output_folder_problem(f.output, plan.make_folders); !why.empty())
            throw Error(why);
        const auto src = ImageSource::open(f.input, settings.max_pixels);  // the header only
        const SourceInfo& info = src->info();
        f.width = info.width;
        f.height = info.height;
        f.channels = info.channels;
        f.format = info.format_name;
        const Linearizer lin = Linearizer::make(ColourRequest{
            settings.data_dir, settings.config, settings.colorspace, f.input, info.colour});
        f.colorspace = lin.input_space();
        f.colorspace_how = lin.how_chosen();
    } catch (const Error& e) {
        f.action = DryRunAction::Fail;
        f.error = e.what();
    } catch (const std::exception& e) {
        f.action = DryRunAction::Fail;
        f.error = f.input + ": " + e.what();
    }
    return f;
}

bool OutputNaming::per_input() const { return !output_dir.empty() || has_template_tokens(output); }

std::vector<std::string> list_inputs(const std::vector<std::string>& given,
                                     const std::string& from_list) {
    std::vector<std::string> listed = given;
    if (!from_list.empty()) {
        auto more = read_list(from_list);
        if (more.empty() && given.empty())
            throw Error(
                (from_list == "-" ? std::string("standard input (--from-list -)") : from_list) +
                ": the input list names no files, and no input was given");
        listed.insert(listed.end(), more.begin(), more.end());
    }
    return listed;
}

std::vector<std::string> expand_inputs(const std::vector<std::string>& listed) {
    std::vector<std::string> expanded;
    for (const auto& in : listed) {
        auto tiles = expand_tiles(in);
        expanded.insert(expanded.end(), tiles.begin(), tiles.end());
    }
    std::sort(expanded.begin(), expanded.end());
    expanded.erase(std::unique(expanded.begin(), expanded.end()), expanded.end());
    return expanded;
}

std::vector<std::pair<std::string, std::string>> name_outputs(
    const std::vector<std::string>& inputs, const OutputNaming& naming) {
    std::vector<std::pair<std::string, std::string>> files;
    for (const auto& in : inputs) {
        if (!naming.base_dir.empty()) (void)relative_folder(in, naming.base_dir);
        std::string out = naming.per_input()
                              ? output_for(in, naming.output, naming.output_dir, naming.base_dir)
                              : naming.output;
        files.push_back({in, out});
    }
    return files;
}

void size_batch_threads(BatchPlan& plan, int jobs, int threads) {
    // Threads by what the work can use: no more jobs than files, and jobs x threads within the
    // process's thread budget (task_pool.h), whatever --jobs x --threads asks.
    const int files = static_cast<int>(std::min<size_t>(plan.files.size(), 1u << 30));
    plan.jobs = std::max(1, std::min(jobs, std::max(1, files)));
    plan.threads = threads > 0 ? threads : std::max(1, hardware_threads() / plan.jobs);
    plan.threads = std::min(plan.threads, std::max(1, thread_budget() / plan.jobs));
    // The task pool: jobs - 1 workers besides the caller, and per job a strip producer and
    // `threads` compressions, as many threads as each of those had of its own before the pool
    // (reserve() stops at the budget).
    TaskPool::shared().reserve(plan.jobs * (plan.threads + 2) - 1);
    // OpenEXR's pool is global to the process: size it for all jobs together.
    Imf::setGlobalThreadCount(std::min(plan.jobs * plan.threads, thread_budget()));
    set_image_threads(plan.threads);  // applied if and when an image is decoded
}

BatchOutcome bake_batch(const BatchPlan& plan, const BakeSettings& settings,
                        BatchListener& listener) {
    const size_t total = plan.files.size();
    const int jobs = std::max(1, std::min<int>(plan.jobs, static_cast<int>(total)));
    BatchRun run(plan, settings, listener, static_cast<size_t>(jobs));
    // Progress within files: a few times a second on a terminal, every 10 s in a log.
    std::mutex tick_mutex;
    std::condition_variable tick_cv;
    bool finished = false;
    std::thread ticker;
    if (plan.progress)
        ticker = std::thread([&] {
            const auto period = progress_period(plan.progress_terminal);
            std::unique_lock<std::mutex> lock(tick_mutex);
            while (!tick_cv.wait_for(lock, period, [&] { return finished; })) {
                std::lock_guard<std::mutex> io_lock(run.io);
                bool busy = false;
                for (const auto& sl : run.slots)
                    busy = busy || (!sl.input.empty() && sl.rows.rows_total.load() > 0);
                if (busy) listener.progress(run.outcome.counts, run.slots);
            }
        });
    // One task per job, each taking the next file until none is left (or --fail-fast stops it).
    TaskPool::shared().parallel_for(static_cast<size_t>(jobs), jobs,
                                    [&run](size_t job) { run.worker(job); });
    if (ticker.joinable()) {
        {
            std::lock_guard<std::mutex> lock(tick_mutex);
            finished = true;
        }
        tick_cv.notify_all();
        ticker.join();
    }
    run.outcome.signal = termination_requested();
    return std::move(run.outcome);
}

}  // namespace spectex
