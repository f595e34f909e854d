#include "cli/batch_runner.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <thread>

#include "cli/commands.h"
#include "pipeline/batch.h"
#include "spectral/error.h"

namespace spectex {

namespace {

std::string seconds_text(double s) {
    char buf[32];
    if (s < 60) std::snprintf(buf, sizeof buf, "%.1f s", s);
    else std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
    return buf;
}

}  // namespace

int run_batch(const BatchPlan& plan, const BakeSettings& settings) {
    const auto t0 = std::chrono::steady_clock::now();
    const size_t total = plan.files.size();
    std::mutex io;
    std::ofstream json_file;
    std::ostream* json = nullptr;
    if (plan.json == "-") {
        json = &std::cout;
    } else if (!plan.json.empty()) {
        json_file.open(plan.json, std::ios::out | std::ios::trunc);
        if (!json_file) {
            print_error(plan.json + ": cannot write the JSON report");
            return 1;
        }
        json = &json_file;
    }

    // Two inputs must never race for one output inside a batch.
    std::map<std::string, std::string> first_input_of;
    std::vector<std::string> clash(total);
    for (size_t i = 0; i < total; ++i) {
        auto [it, fresh] = first_input_of.emplace(plan.files[i].second, plan.files[i].first);
        if (!fresh) clash[i] = plan.files[i].second + ": also the output of " + it->second + "; not baked twice";
    }

    std::atomic<size_t> next{0};
    std::atomic<bool> stop{false};
    size_t done = 0, ok = 0, skipped = 0, failed = 0;

    auto report = [&](const FileRecord& r) {
        std::lock_guard<std::mutex> lock(io);
        if (plan.progress) std::cerr << "\r\033[K";
        if (r.status == "failed") {
            print_error(r.error);
        } else if (!plan.quiet) {
            for (const auto& n : r.result.notes) std::cerr << "spectex: " << r.input << ": note: " << n << "\n";
            if (r.result.clamped_pixels)
                std::cerr << "spectex: " << r.input << ": " << r.result.clamped_pixels
                          << " pixels had linear values outside [0, 1] and were clamped\n";
            if (r.result.replaced_pixels)
                std::cerr << "spectex: " << r.input << ": " << r.result.replaced_pixels
                          << " pixels had NaN/Inf values replaced with 0\n";
        }
        if (plan.verbose && r.status == "ok")
            std::cerr << "spectex: " << r.input << " -> " << r.output << ": " << r.result.pixels << " pixels, "
                      << r.result.bins << " bins, colour space '" << r.result.colorspace << "' ("
                      << r.result.colorspace_how << "), " << r.result.bytes << " bytes, "
                      << seconds_text(r.result.seconds) << "\n";
        if (plan.verbose && r.status == "ok") {
            const auto& st = r.result.stages;
            char buf[400];
            std::snprintf(buf, sizeof buf,
                          "spectex: %s: stages: read %.2f s, colour %.2f s, expand %.2f s (producer thread); "
                          "pack %.2f s, waiting for the encoder %.2f s, for the producer %.2f s, finish %.2f s "
                          "(writer thread); compress %.2f CPU-s (%s writer)\n",
                          r.input.c_str(), st.read, st.colour, st.expand, st.pack, st.encoder_wait, st.producer_wait,
                          st.finish, st.compress_cpu, st.writer.c_str());
            std::cerr << buf;
        }
        if (plan.verbose && r.status == "skipped") std::cerr << "spectex: " << r.output << ": up to date\n";
        if (json) {
            *json << json_record(r) << "\n";
            json->flush();
        }
        ++done;
        ok += r.status == "ok";
        skipped += r.status == "skipped";
        failed += r.status == "failed";
        if (plan.progress) {
            double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            double eta = done ? el / static_cast<double>(done) * static_cast<double>(total - done) : 0;
            std::cerr << "spectex: [" << done << "/" << total << "] " << failed << " failed, ETA "
                      << seconds_text(eta) << std::flush;
        }
    };

    auto worker = [&] {
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
                if (plan.update && up_to_date(r.input, r.output, settings.settings_hash)) {
                    r.status = "skipped";
                } else {
                    r.result = bake_file(r.input, r.output, settings);
                    r.status = "ok";
                }
            } catch (const Error& e) {
                r.status = "failed";
                r.error = e.what();
            } catch (const std::exception& e) {
                r.status = "failed";
                r.error = r.input + ": " + e.what();
            }
            r.result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            if (r.status == "failed" && plan.fail_fast) stop.store(true);
            report(r);
        }
    };
    const int jobs = std::max(1, std::min<int>(plan.jobs, static_cast<int>(total)));
    std::vector<std::thread> pool;
    for (int j = 1; j < jobs; ++j) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();

    if (plan.progress) std::cerr << "\r\033[K";
    const size_t not_attempted = total - done;
    if (!plan.quiet && (total > 1 || failed || skipped)) {
        double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::cerr << "spectex: " << ok << " baked, " << skipped << " up to date, " << failed << " failed";
        if (not_attempted) std::cerr << ", " << not_attempted << " not attempted (--fail-fast)";
        std::cerr << " of " << total << " in " << seconds_text(el) << "\n";
    }
    return failed || not_attempted ? 1 : 0;
}

}  // namespace spectex
