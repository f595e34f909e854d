#include "pipeline/table_memo.h"

#include <utility>

#include "base/memo.h"

namespace spectex {

namespace {

// Enough for every light a scene names; past it the memo starts afresh (reads again, never wrong).
constexpr size_t kTables = 64;

}  // namespace

std::shared_ptr<const Observer> observer_table(const std::string& data_dir,
                                               const std::string& name) {
    static Memo<std::pair<std::string, std::string>, std::shared_ptr<const Observer>> memo(kTables);
    return memo.get({data_dir, name}, [&] {
        return std::make_shared<const Observer>(load_observer(data_dir, name));
    });
}

std::shared_ptr<const Spectrum> illuminant_table(const std::string& data_dir,
                                                 const std::string& name_or_file) {
    static Memo<std::pair<std::string, std::string>, std::shared_ptr<const Spectrum>> memo(kTables);
    return memo.get({data_dir, name_or_file}, [&] {
        return std::make_shared<const Spectrum>(load_illuminant(data_dir, name_or_file));
    });
}

std::shared_ptr<const MeasuredPrior> measured_prior_table(const std::string& data_dir) {
    static Memo<std::string, std::shared_ptr<const MeasuredPrior>> memo(kTables);
    return memo.get(data_dir, [&] {
        return std::make_shared<const MeasuredPrior>(
            read_measured_prior_csv(measured_prior_path(data_dir)));
    });
}

}  // namespace spectex
