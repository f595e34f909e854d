#pragma once
// One exception type for the whole library: the CLI prints it as "spectex: <file>: <cause>".
#include <stdexcept>
#include <string>

namespace spectex {

class Error : public std::runtime_error {
  public:
    explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace spectex
