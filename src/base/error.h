#pragma once
// One exception type for the whole library: the CLI prints it as "spectex: <file>: <cause>".
#include <stdexcept>
#include <string>

namespace spectex {

class Error : public std::runtime_error {
  public:
    explicit Error(const std::string& what) : std::runtime_error(what) {}
};

// A request whose cost (memory, threads, work) exceeds a documented limit, found before any of
// the work is done. what() is "<option>: <the figure> ... the limit ..."; the CLI reports it as a
// usage error (exit 2): the command line asked for it, not the data.
class LimitError : public Error {
  public:
    explicit LimitError(const std::string& what) : Error(what) {}
};

}  // namespace spectex
