#include "base/run_clock.h"

namespace spectex {

namespace {
const std::chrono::steady_clock::time_point kStart = std::chrono::steady_clock::now();
}  // namespace

std::chrono::steady_clock::time_point process_start() { return kStart; }

}  // namespace spectex
