#pragma once
// One function per subcommand: parse options, call the library, report. Return the exit status
// (0 ok, 1 failed work, 2 usage error).
#include <string>
#include <vector>

namespace spectex {

int run_bake(const std::vector<std::string>& args, const std::string& command_line);
int run_info(const std::vector<std::string>& args);
int run_basis(const std::vector<std::string>& args, const std::string& command_line);
int run_verify(const std::vector<std::string>& args);

// Prints "spectex: <message>" to stderr.
void print_error(const std::string& message);
// Prints "spectex <command>: <message>" and a hint to run --help; returns 2.
int usage_error(const std::string& command, const std::string& message);

}  // namespace spectex
