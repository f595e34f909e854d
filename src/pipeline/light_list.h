#pragma once
// The lights a command is asked for, each once. Every light costs per light (verify keeps its
// accumulators per light and per thread, plan measures every grid under every light, render
// draws a panel per light), so `--illuminant A,a,A` is one light: a shipped name in any case, or
// one CSV file however it is spelt (d/l.csv, d/./l.csv, a link to it: its identity).
#include <string>
#include <vector>

namespace spectex {

// `names` with the repeats left out, in the order first given (the first spelling is kept, so
// reports name the light as the user first wrote it; a colour temperature is named canonically,
// "3200 k" as 3200K, so 3200K and 3200k are one light). A name that is neither a shipped light, a
// temperature nor an existing file is kept as given (its loader reports it).
std::vector<std::string> distinct_lights(const std::vector<std::string>& names);

// A light's name as reports and headers record it: a colour temperature canonical ("3200k" ->
// "3200K"), anything else as given (a malformed temperature too: its loader reports it).
std::string light_name(const std::string& name);

}  // namespace spectex
