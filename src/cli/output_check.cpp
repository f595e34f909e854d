#include "cli/output_check.h"

#include <filesystem>

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
    check_output(output, role, files, stream_ok, false);
}

void check_output(const std::string& output, const std::string& role, const ReadFiles& reads,
                  bool stream_ok, bool name_role) {
    if (std::string clash = reads.clash(output, role); !clash.empty()) throw UsageError(clash);
    std::error_code ec;  // a link loop is reported by check_output_path, not thrown past main
    if (!output.empty() && (output.back() == '/' || std::filesystem::is_directory(output, ec)))
        throw UsageError(role + ": '" + output + "' is a folder; give a file name");
    try {
        check_output_path(output, stream_ok);
    } catch (const Error& e) {
        throw UsageError(std::string(e.what()) + (name_role ? " (" + role + ")" : ""));
    }
}

}  // namespace spectex
