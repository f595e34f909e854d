#include "cli/output_check.h"

#include "base/error.h"
#include "cli/arg_parser.h"
#include "io/atomic_file.h"
#include "io/data_dir.h"
#include "io/file_identity.h"

namespace spectex {

void check_output_against(const std::string& output, const std::string& role,
                          const std::vector<std::pair<std::string, std::string>>& reads,
                          bool stream_ok) {
    ReadFiles files;
    try {
        files.add_data_dir(find_data_dir());  // the shipped tables are read by name
    } catch (const Error&) {
        // No data folder: the command reports that itself.
    }
    for (const auto& [path, what] : reads) files.add(path, what);
    if (std::string clash = files.clash(output, role); !clash.empty()) throw UsageError(clash);
    try {
        check_output_path(output, stream_ok);
    } catch (const Error& e) {
        throw UsageError(e.what());
    }
}

}  // namespace spectex
