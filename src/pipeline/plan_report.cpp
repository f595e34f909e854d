#include "pipeline/plan_report.h"

#include <cstdio>
#include <sstream>

#include "base/text.h"
#include "pipeline/json_text.h"
#include "spectral/precision.h"

namespace spectex {

namespace {

std::string fmt(double v, const char* f = "%.3g") { return number_text(v, f); }

// "400,412.5,425": the wavelengths, shortest decimals.
std::string wavelength_list(const WavelengthGrid& g) {
    std::string out;
    for (double l : g.lambda) out += (out.empty() ? "" : ",") + format_wavelength(l);
    return out;
}

}  // namespace

std::string plan_table(const PlanSpec& spec, const PlanResult& r) {
    std::ostringstream o;
    std::string lights;
    for (const auto& l : spec.lights) lights += (lights.empty() ? "" : ", ") + l;
    o << "spectex plan: budget " << fmt(spec.max_de) << " ΔE00 (worst colour) under " << lights
      << "\n";
    o << "  renderer: " << to_string(spec.reconstruction) << " reconstruction, held past the ends, "
      << fmt(spec.range_start, "%g") << "-" << fmt(spec.range_end, "%g") << " nm at 1 nm\n";
    o << "  method:   " << r.method << ", " << (spec.half ? "half" : "float") << "\n";
    o << "  colours:  " << r.colours << "\n";
    o << "  time:     relative to 81 bins, modelled as 0.24 + 0.76 * bins / 81; bytes: spectral "
         "channels only\n\n";
    char buf[256];
    std::snprintf(buf, sizeof buf, "  %-15s %5s %6s %5s %-6s", "grid", "bins", "B/px", "time",
                  "over");
    o << buf;
    for (const auto& l : spec.lights) {
        std::snprintf(buf, sizeof buf, "  %15s", (l + " worst/p99").c_str());
        o << buf;
    }
    o << "  verdict\n";
    for (size_t i = 0; i < r.rows.size(); ++i) {
        const GridRow& row = r.rows[i];
        std::snprintf(buf, sizeof buf, "%s %-15s %5d %6d %5.2f %-6s",
                      static_cast<int>(i) == r.chosen ? "*" : " ", grid_label(row.grid).c_str(),
                      row.bins, row.bytes_per_pixel, row.relative_time, row.colours.c_str());
        o << buf;
        for (const auto& le : row.lights) {
            std::string cell = row.ok ? fmt(le.worst) + " / " + fmt(le.p99) : "-";
            std::snprintf(buf, sizeof buf, "  %15s", cell.c_str());
            o << buf;
        }
        o << "  " << row.why << "\n";
    }
    o << "\n";
    for (const auto& row : r.rows)
        if (!row.grid.uniform)
            o << "  " << grid_label(row.grid) << ": " << wavelength_list(row.grid) << " nm\n";
    if (!r.search.empty()) o << "  " << r.search << "\n\n";
    if (r.chosen >= 0)
        o << "* " << grid_label(r.rows[static_cast<size_t>(r.chosen)].grid)
          << ": the cheapest grid within " << fmt(spec.max_de) << " ΔE00 under every light (worst "
          << fmt(r.rows[static_cast<size_t>(r.chosen)].worst) << " under "
          << r.rows[static_cast<size_t>(r.chosen)].worst_light << ")\n";
    else
        o << plan_failure(spec, r) << "\n";
    if (!r.precision_bits.empty()) {
        // Bins and bits together: what the scene needs of the spectrum and of each bin.
        std::string names, worst;
        for (size_t j = 0; j < r.precision_lights.size(); ++j) {
            names += (names.empty() ? "" : ", ") + r.precision_lights[j];
            worst += (worst.empty() ? "" : ", ") + r.precision_lights[j] + " " +
                     fmt(r.precision_worst[j]);
        }
        o << "  precision: " << r.precision_bits.size() << " bins, mantissa bits "
          << format_precision_bits(r.precision_bits) << " ("
          << fmt(100 * kept_fraction(r.precision_bits), "%.0f")
          << "% of half's), the file against the method at 1 nm within " << fmt(r.precision_de)
          << " ΔE00 under " << names << " (worst " << worst << ")\n";
    }
    o << "  (" << fmt(r.seconds, "%.1f") << " s)\n";
    return o.str();
}

std::string plan_failure(const PlanSpec& spec, const PlanResult& r) {
    std::string s = "no candidate grid meets " + fmt(spec.max_de) + " ΔE00 under every light";
    if (r.best >= 0) {
        const GridRow& b = r.rows[static_cast<size_t>(r.best)];
        s += ": the best achievable is " + fmt(b.worst) + " (" + grid_label(b.grid) + ", under " +
             b.worst_light + ")";
    } else {
        s += ": the method could not be built on any of them";
    }
    return s;
}

std::string plan_json(const PlanSpec& spec, const PlanResult& r) {
    auto num = [](double v) { return json_number(v, "%.6g"); };
    Json j;
    j["schema_version"] = 1;
    put_texts(j, "lights", spec.lights);
    j["max_de"] = num(spec.max_de);
    j["reconstruction"] = to_string(spec.reconstruction);
    j["range"] = {num(spec.range_start), num(spec.range_end)};
    put_text(j, "method", r.method);
    j["type"] = spec.half ? "half" : "float";
    put_text(j, "colours", r.colours);
    j["nonuniform"] = spec.nonuniform;
    put_text(j, "search", r.search);
    j["seconds"] = num(r.seconds);
    j["chosen"] = r.chosen >= 0 ? Json(grid_label(r.rows[static_cast<size_t>(r.chosen)].grid))
                                : Json(nullptr);
    if (r.best >= 0) {
        const GridRow& best = r.rows[static_cast<size_t>(r.best)];
        j["best"] = {{"grid", grid_label(best.grid)}, {"worst", num(best.worst)}};
    } else {
        j["best"] = nullptr;
    }
    Json grids = Json::array();
    for (size_t i = 0; i < r.rows.size(); ++i) {
        const GridRow& row = r.rows[i];
        Json g;
        g["grid"] = grid_label(row.grid);
        g["start"] = num(row.grid.lambda.front());
        g["end"] = num(row.grid.lambda.back());
        g["step"] = row.grid.uniform ? num(row.grid.step) : Json(nullptr);
        g["uniform"] = row.grid.uniform;
        Json wavelengths = Json::array();
        for (double l : row.grid.lambda)
            wavelengths.push_back(json_number_text(format_wavelength(l)));
        g["wavelengths"] = std::move(wavelengths);
        g["bins"] = row.bins;
        g["bytes_per_pixel"] = row.bytes_per_pixel;
        g["relative_time"] = num(row.relative_time);
        put_text(g, "colours", row.colours);
        g["built"] = row.ok;
        g["passes"] = row.passes;
        g["chosen"] = static_cast<int>(i) == r.chosen;
        put_text(g, "why", row.why);
        g["worst"] = row.ok ? num(row.worst) : Json(nullptr);
        put_text(g, "worst_light", row.worst_light);
        Json lights = Json::array();
        for (size_t k = 0; row.ok && k < row.lights.size(); ++k) {
            const LightError& le = row.lights[k];
            Json l;
            put_text(l, "light", le.light);
            l["worst"] = num(le.worst);
            l["p99"] = num(le.p99);
            l["half_shift"] = num(le.half_shift);
            l["worst_code"] = le.worst_code;
            lights.push_back(std::move(l));
        }
        g["lights"] = std::move(lights);
        grids.push_back(std::move(g));
    }
    j["grids"] = std::move(grids);
    if (!r.precision_bits.empty()) {
        Json pj;
        pj["bits"] = r.precision_bits;
        pj["max_de"] = num(r.precision_de);
        put_texts(pj, "lights", r.precision_lights);
        Json worst = Json::array();
        for (double w : r.precision_worst) worst.push_back(num(w));
        pj["worst"] = std::move(worst);
        j["precision"] = std::move(pj);
    }
    return json_line(j);
}

}  // namespace spectex
