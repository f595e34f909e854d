#pragma once
// The one check every command makes of an output before any work (a usage error, exit 2): it is
// none of the files the command reads, compared by identity (those given, plus the tables and
// config spectex ships), and it can be an output at all (io/atomic_file.h check_output_path: not a
// device, FIFO, socket or a link to one; a name that fits its folder).
#include <string>
#include <utility>
#include <vector>

namespace spectex {

class ReadFiles;

// An output checked against the files the command reads (reads.clash: exit 2 naming both), not a
// folder ("<role>: '<output>' is a folder; give a file name"), and a place an output can be
// (check_output_path; its cause followed by " (<role>)" when `name_role`). Throws UsageError.
void check_output(const std::string& output, const std::string& role, const ReadFiles& reads,
                  bool stream_ok = false, bool name_role = true);

// reads: (path, role) of every file the command reads besides the shipped data. Throws UsageError.
// stream_ok: a text output, which may name a stream (/dev/stdout, a link into /proc/self/fd) and
// is then written through to it.
void check_output_against(const std::string& output, const std::string& role,
                          const std::vector<std::pair<std::string, std::string>>& reads,
                          bool stream_ok = false);

}  // namespace spectex
