#pragma once
// When this process started, for figures that speak of the whole run.
#include <chrono>

namespace spectex {

// The time of the process's static initialisation, before main: a batch's summary says how long
// the run took (start-up, the list, the --update checks included), not how long since its report
// was made.
std::chrono::steady_clock::time_point process_start();

}  // namespace spectex
