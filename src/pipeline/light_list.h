#pragma once
// The lights a command is asked for, each once. Every light costs per light (verify keeps its
// accumulators per light and per thread, plan measures every grid under every light, render
// draws a panel per light), so `--illuminant A,a,A` is one light: a shipped name in any case, or
// one CSV file however it is spelt (d/l.csv, d/./l.csv, a link to it: its identity).
#include <string>
#include <vector>

namespace spectex {

// `names` with the repeats left out, in the order first given (the first spelling is kept, so
// reports name the light as the user first wrote it). A name that is neither a shipped light nor
// an existing file is kept as given (its loader reports it).
std::vector<std::string> distinct_lights(const std::vector<std::string>& names);

}  // namespace spectex
