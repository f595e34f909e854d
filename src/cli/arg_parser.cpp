#include "cli/arg_parser.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <sstream>

#include "base/error.h"
#include "base/text.h"
#include "io/data_dir.h"
#include "io/linearizer.h"
#include "spectral/basis_fit.h"
#include "spectral/colour_temperature.h"
#include "spectral/lattice.h"
#include "spectral/spectrum.h"

namespace spectex {

ArgParser::ArgParser(std::string command, std::string synopsis, std::string description)
    : command_(std::move(command)),
      synopsis_(std::move(synopsis)),
      description_(std::move(description)) {
    flag("-h, --help", "Show this help and exit.", [this] { help_ = true; });
}

void ArgParser::section(const std::string& title) {
    Entry e;
    e.label = title;
    e.is_section = true;
    entries_.push_back(e);
}

static std::vector<std::string> split_names(const std::string& names) {
    std::vector<std::string> out;
    std::stringstream ss(names);
    std::string item;
    while (std::getline(ss, item, ',')) {
        size_t a = item.find_first_not_of(' ');
        size_t b = item.find_last_not_of(' ');
        if (a != std::string::npos) out.push_back(item.substr(a, b - a + 1));
    }
    return out;
}

void ArgParser::flag(const std::string& names, const std::string& help, std::function<void()> on) {
    Entry e;
    e.names = split_names(names);
    e.label = names;
    e.help = help;
    e.on_flag = std::move(on);
    entries_.push_back(e);
}

void ArgParser::option(const std::string& names, const std::string& metavar,
                       const std::string& help, std::function<void(const std::string&)> on) {
    Entry e;
    e.names = split_names(names);
    e.label = names + " " + metavar;
    e.metavar = metavar;
    e.help = help;
    e.on_value = std::move(on);
    entries_.push_back(e);
}

void ArgParser::option_or_flag(const std::string& names, const std::string& metavar,
                               const std::string& help, std::vector<std::string> suffixes,
                               std::string bare, std::function<void(const std::string&)> on) {
    Entry e;
    e.names = split_names(names);
    e.label = names + " [" + metavar + "]";
    e.metavar = metavar;
    e.help = help;
    e.on_value = std::move(on);
    e.value_optional = true;
    e.suffixes = std::move(suffixes);
    e.bare = std::move(bare);
    entries_.push_back(e);
}

const ArgParser::Entry* ArgParser::find(const std::string& name) const {
    for (const auto& e : entries_)
        for (const auto& n : e.names)
            if (n == name) return &e;
    return nullptr;
}

bool ArgParser::parse_or_help(const std::vector<std::string>& args,
                              std::vector<std::string>& positional) {
    positional = parse(args);
    if (help_) std::cout << help();
    return help_;
}

std::vector<std::string> ArgParser::parse(const std::vector<std::string>& args) {
    std::vector<std::string> pos;
    for (size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (a == "--") {
            pos.insert(pos.end(), args.begin() + static_cast<long>(i) + 1, args.end());
            break;
        }
        if (a.empty())
            throw UsageError("an empty argument ('') names no file (an unset shell variable?)");
        if (a.size() < 2 || a[0] != '-' || a == "-") {
            pos.push_back(a);
            continue;
        }
        std::string name = a, value;
        bool inline_value = false;
        if (a.compare(0, 2, "--") == 0) {
            size_t eq = a.find('=');
            if (eq != std::string::npos) {
                name = a.substr(0, eq);
                value = a.substr(eq + 1);
                inline_value = true;
            }
        }
        const Entry* e = find(name);
        if (!e) {
            std::vector<std::string> known;
            for (const auto& en : entries_)
                for (const auto& n : en.names)
                    if (n.size() > 2) known.push_back(n);
            const auto close = close_colour_space_names(known, name, 1);  // closest names, any kind
            throw UsageError("unknown option '" + name + "'" +
                             (close.empty() ? "" : " (did you mean " + close[0] + "?)"));
        }
        if (e->on_flag) {
            if (inline_value) throw UsageError("option '" + name + "' takes no value");
            e->on_flag();
            given_.push_back({e->names.back(), "", false});
            if (help_) return pos;
            continue;
        }
        if (!inline_value && e->value_optional) {
            const std::string next = i + 1 < args.size() ? args[i + 1] : "";
            bool takes = next == "-";
            for (const auto& suffix : e->suffixes)
                takes = takes ||
                        (next.size() > suffix.size() &&
                         next.compare(next.size() - suffix.size(), suffix.size(), suffix) == 0);
            if (!takes && !next.empty() && next[0] != '-')
                declined_.push_back({e->names.back(), next});
            value = takes ? args[++i] : e->bare;
            inline_value = true;
        }
        if (!inline_value) {
            if (i + 1 >= args.size())
                throw UsageError("option '" + name + "' needs a value (" + e->metavar + ")");
            value = args[++i];
        }
        // No option of spectex takes an empty value: "" is a mistake (an unset shell variable),
        // never "use the default".
        if (value.empty())
            throw UsageError("option '" + name + "' needs a value (" + e->metavar + "), not ''");
        e->on_value(value);
        given_.push_back({e->names.back(), value, true});
    }
    return pos;
}

void ArgParser::common(std::vector<std::string> names) { common_ = std::move(names); }

std::string ArgParser::declined_hint(const std::string& name, const std::string& arg) const {
    if (std::find(declined_.begin(), declined_.end(), std::make_pair(name, arg)) == declined_.end())
        return "";
    const Entry* e = find(name);
    std::string suffixes;
    for (size_t i = 0; e && i < e->suffixes.size(); ++i)
        suffixes += (i ? (i + 1 == e->suffixes.size() ? " or " : ", ") : "") + e->suffixes[i];
    return " (it followed " + name + ", which takes a FILE only when it ends in " + suffixes +
           " or is given as " + name + "=FILE: it was read as an argument" +
           (e && e->bare == "-" ? ", and " + name + " alone means standard output)" : ")");
}

void ArgParser::describe(std::ostringstream& o, const Entry& e) const {
    std::string label = "  " + e.label;
    if (label.size() < 28) {
        o << label << std::string(28 - label.size(), ' ');
    } else {
        o << label << "\n" << std::string(28, ' ');
    }
    // Wrap the help at 100 columns.
    std::istringstream words(e.help);
    std::string word;
    size_t col = 28;
    bool first = true;
    while (words >> word) {
        if (!first && col + 1 + word.size() > 100) {
            o << "\n" << std::string(28, ' ');
            col = 28;
            first = true;
        }
        if (!first) {
            o << ' ';
            ++col;
        }
        o << word;
        col += word.size();
        first = false;
    }
    o << "\n";
}

std::string ArgParser::help() const {
    std::ostringstream o;
    o << "Usage: " << synopsis_ << "\n\n" << description_ << "\n";
    std::vector<const Entry*> shown;
    if (!common_.empty()) {
        o << "\nCommon options:\n";
        for (const std::string& name : common_) {
            const Entry* e = find(name);
            if (e == nullptr)
                throw std::logic_error("common option '" + name + "' is not declared");
            describe(o, *e);
            shown.push_back(e);
        }
    }
    // A section whose options are all common is left out with them; options declared outside any
    // section follow the common ones under a heading of their own.
    bool headed = common_.empty();
    for (size_t i = 0; i < entries_.size(); ++i) {
        const Entry& e = entries_[i];
        if (std::find(shown.begin(), shown.end(), &e) != shown.end()) continue;
        if (e.is_section) {
            bool any = false;
            for (size_t j = i + 1; j < entries_.size() && !entries_[j].is_section; ++j)
                any = any || std::find(shown.begin(), shown.end(), &entries_[j]) == shown.end();
            if (any) o << "\n" << e.label << ":\n";
            headed = true;
            continue;
        }
        if (!headed) o << "\nOther options:\n";
        headed = true;
        describe(o, e);
    }
    return o.str();
}

int parse_int(const std::string& option, const std::string& value, int min, int max) {
    long long v = 0;
    if (!parse_whole(value, min, max, &v))
        throw UsageError(option + ": '" + value + "' is not a whole number from " +
                         std::to_string(min) + " to " + std::to_string(max));
    return static_cast<int>(v);
}

double parse_number(const std::string& option, const std::string& value) {
    double v = 0;
    if (!parse_finite(value, &v)) throw UsageError(option + ": '" + value + "' is not a number");
    return v;
}

std::string parse_word(const std::string& option, const std::string& value,
                       const std::vector<std::string>& words) {
    std::string list;
    for (const auto& w : words) {
        if (same_word(w, value)) return w;
        list += (list.empty() ? "" : ", ") + w;
    }
    throw UsageError(option + ": '" + value + "' is not one of " + list);
}

double parse_budget_de(const std::string& option, const std::string& value) {
    const double v = parse_number(option, value);
    if (!(v > 0)) throw UsageError(option + ": '" + value + "' is not a positive ΔE00");
    return v;
}

void require_one_input(const std::vector<std::string>& files) {
    if (files.empty()) throw UsageError("no input file");
    if (files.size() > 1)
        throw UsageError("one file at a time (got " + std::to_string(files.size()) + ")");
}

std::string vertex_prior_option(const std::string& value) {
    try {
        return to_string(parse_vertex_prior(value));
    } catch (const Error&) {
        throw UsageError("--vertex-prior: '" + value + "' is not one of " +
                         kVertexPriorNames.list(", ", " or "));
    }
}

FitObjective parse_objective_option(const std::string& value) {
    try {
        return parse_objective(value);
    } catch (const Error&) {
        throw UsageError("--objective: '" + value + "' is not one of smooth, norm");
    }
}

uint64_t parse_count(const std::string& option, const std::string& value) {
    long long v = 0;
    if (!parse_whole(value, 1, std::numeric_limits<long long>::max(), &v))
        throw UsageError(option + ": '" + value + "' is not a positive whole number");
    return static_cast<uint64_t>(v);
}

void list_option(ArgParser& p, const std::string& names, const std::string& metavar,
                 const std::string& help, std::vector<std::string>& items) {
    const std::string option = names.substr(names.rfind(',') + 1);
    p.option(names, metavar, help, [&items, option](const std::string& v) {
        for (const auto& n : split_list(v, option)) items.push_back(n);
    });
}

void observer_option(ArgParser& p, const std::string& whose, std::string& observer) {
    p.option("--observer", "NAME|FILE",
             whose +
                 ": cie1931-2 (default), cie1964-10, or a CSV wavelength,x,y,z (header: a "
                 "wavelength column, e.g. \"Wavelength (nm)\", then 3 named columns; or none). "
                 "A singular "
                 "one (x, y, z linearly dependent) is refused.",
             [&observer](const std::string& v) { observer = v; });
}

namespace {

// A table option's value, loaded now so that an unknown name, an unreadable or malformed file or
// a singular table is a usage error naming the option, before any input is read.
template <class Load>
void check_table_setting(const std::string& option, const std::string& name, Load load) {
    if (name.empty()) return;
    const std::string data_dir = find_data_dir();  // no data folder: the command's own error
    try {
        load(data_dir, name);
    } catch (const Error& e) {
        throw UsageError(option + ": " + e.what());
    }
}

}  // namespace

void check_observer_setting(const std::string& option, const std::string& name) {
    check_table_setting(option, name,
                        [](const std::string& d, const std::string& n) { load_observer(d, n); });
}

void check_illuminant_setting(const std::string& option, const std::string& name) {
    check_table_setting(option, name,
                        [](const std::string& d, const std::string& n) { load_illuminant(d, n); });
}

std::string colour_temperature_help() {
    return "a colour temperature from " + colour_temperature_name(kMinColourTemperature) + " to " +
           colour_temperature_name(kMaxColourTemperature) + " (e.g. 3200K or 3200k: a Planckian " +
           "radiator below " + colour_temperature_name(kDaylightFromTemperature) +
           ", CIE daylight from it; D65 is about 6504K)";
}

std::vector<std::string> split_list(const std::string& value, const std::string& option) {
    std::vector<std::string> out;
    size_t start = 0;
    while (true) {
        const size_t comma = value.find(',', start);
        std::string item =
            value.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        const size_t b = item.find_first_not_of(" \t"), e = item.find_last_not_of(" \t");
        item = b == std::string::npos ? std::string() : item.substr(b, e - b + 1);
        if (item.empty())
            throw UsageError((option.empty() ? std::string() : option + ": ") + "empty name in '" +
                             value + "'");
        out.push_back(item);
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    return out;
}

std::string join_names(const std::vector<std::string>& names) {
    std::string s;
    for (size_t i = 0; i < names.size(); ++i) s += (i ? ", " : "") + names[i];
    return s;
}

std::pair<int, int> parse_pixel(const std::string& option, const std::string& value) {
    // Any coordinate an OpenEXR data window can hold (an int); whether the file has that pixel
    // is the reader's question (exit 1, "outside the data window").
    auto whole = [&](const std::string& part, int* out) {
        long long v = 0;
        const bool ok =
            parse_whole(part, std::numeric_limits<int>::min(), std::numeric_limits<int>::max(), &v);
        *out = static_cast<int>(v);
        return ok;
    };
    const size_t comma = value.find(',');
    std::pair<int, int> p;
    if (comma == std::string::npos || !whole(value.substr(0, comma), &p.first) ||
        !whole(value.substr(comma + 1), &p.second))
        throw UsageError((option.empty() ? "" : option + ": ") + "'" + value +
                         "' is not a pixel X,Y (two whole numbers)");
    return p;
}

}  // namespace spectex
