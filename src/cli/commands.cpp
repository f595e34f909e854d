// The helpers every command shares (cli/commands.h): how a file is named in an error, how a
// command's work is reported, and what a usage error prints.
#include "cli/commands.h"

#include <exception>
#include <functional>
#include <iostream>
#include <string>

#include "base/error.h"
#include "base/text.h"

namespace spectex {

std::string name_file(const std::string& file, const std::string& message,
                      const std::string& doing) {
    if (file.empty()) return message;
    if (message.compare(0, file.size() + 2, file + ": ") == 0)
        return quote_path(file) + message.substr(file.size());
    if (doing.empty()) return message;
    // The cause is in another file (a source or config the file records, a table), which the
    // line names first as every error line does; the file it happened to is named after it, so
    // that the lines of a batch can be told apart.
    return message + " (" + doing + " " + quote_path(file) + ")";
}

void print_error(const std::string& message) {
    std::cerr << "spectex: " << one_line(message) << std::endl;
}

int run_reporting(const std::string& command, const std::string& file,
                  const std::function<void()>& work) {
    try {
        work();
        return 0;
    } catch (const LimitError& e) {
        return usage_error(command, e.what());
    } catch (const Error& e) {
        print_error(name_file(file, e.what()));
    } catch (const std::exception& e) {
        print_error(quote_path(file) + ": " + e.what());
    }
    return 1;
}

int usage_error(const std::string& command, const std::string& message) {
    std::cerr << "spectex " << command << ": " << one_line(message) << "\n"
              << "Try 'spectex " << command << " --help'." << std::endl;
    return 2;
}

}  // namespace spectex
