// The method table's rows say what each method guarantees; these tests hold every row to its word
// by building the method on a coarse grid and measuring it, so a new row with a wrong flag fails.
#include "pipeline/method_table.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "base/error.h"
#include "spectral/colorimetry.h"
#include "spectral/spectrum.h"
#include "spectral/srgb_axis.h"
#include "temp_dir.h"

namespace spectex {
namespace {

const std::string kData = SPECTEX_TEST_DATA_DIR;

MethodSpec spec_for(const MethodRow& row) {
    MethodSpec s;
    s.kind = row.kind;
    s.fit.data_dir = kData;
    s.fit.grid = WavelengthGrid::parse("380:780:10");
    s.lattice_size = 5;  // small tables: the flags do not depend on the size
    s.jh_resolution = 9;
    return s;
}

// Linear RGB of each colour's spectrum under the method's own colorimetry (D65, CIE 1931 2°).
std::vector<float> expand(const SpectralMethod& m, const std::vector<float>& r,
                          const std::vector<float>& g, const std::vector<float>& b) {
    const size_t n = r.size(), bins = m.lambda().size();
    std::vector<float> out(n * bins);
    m.expand_float(r.data(), g.data(), b.data(), n, out.data(), n);
    return out;
}

TEST(MethodTable, NamesAndOptionsAreUniqueAndFound) {
    std::set<std::string> names, options;
    for (const auto& row : method_table()) {
        EXPECT_TRUE(names.insert(row.name).second) << row.name;
        EXPECT_EQ(find_method(row.name), &row);
        EXPECT_EQ(&method_row(row.kind), &row);
        for (const auto& o : row.options) {
            EXPECT_TRUE(options.insert(o).second) << o << " belongs to two methods";
            EXPECT_EQ(method_of_option(o), &row);
        }
        // A row with a table names the option that sizes it, and that option is its own.
        if (!row.table_option.empty()) {
            EXPECT_EQ(method_of_option(row.table_option), &row);
            EXPECT_FALSE(row.table_nodes.empty());
        }
    }
    EXPECT_EQ(find_method("no-such-method"), nullptr);
    EXPECT_EQ(method_of_option("--threads"), nullptr);
    // The default (the first row) is the one MethodSpec starts with.
    EXPECT_EQ(MethodSpec().name(), method_table().front().name);
    // A method this spectex does not know is gated as exact, not waved through.
    EXPECT_TRUE(method_is_exact("a-method-of-a-later-spectex"));
}

// Linear rows: spectrum(a + b) = spectrum(a) + spectrum(b) within float rounding (1e-5 relative to
// the largest sample: two float expansions of values <= 1); non-linear rows break it by more than
// 1e-3 somewhere (a lattice or sigmoid bends by far more than float rounding).
TEST(MethodTable, LinearFlagMatchesTheBuiltMethod) {
    const std::vector<float> r = {0.1f, 0.3f, 0.05f}, g = {0.2f, 0.1f, 0.4f},
                             b = {0.05f, 0.2f, 0.3f};
    std::vector<float> r2(3), g2(3), b2(3);
    for (size_t i = 0; i < 3; ++i) r2[i] = 2 * r[i], g2[i] = 2 * g[i], b2[i] = 2 * b[i];
    for (const auto& row : method_table()) {
        const MethodResult made = make_method(spec_for(row));
        ASSERT_TRUE(made.method) << row.name;
        EXPECT_EQ(made.method->is_linear(), row.linear) << row.name;
        const std::vector<float> once = expand(*made.method, r, g, b),
                                 twice = expand(*made.method, r2, g2, b2);
        double worst = 0;
        for (size_t i = 0; i < once.size(); ++i)
            worst = std::max(worst, std::abs(double(twice[i]) - 2.0 * once[i]));
        if (row.linear)
            EXPECT_LT(worst, 1e-5) << row.name;
        else
            EXPECT_GT(worst, 1e-3) << row.name;
    }
}

// Exact rows: every colour of a 9^3 sample of the sRGB cube comes back within 1e-5 in linear RGB
// (the float spectra integrated in double; the methods are exact to ~1e-7); the row that is not
// exact misses some colour by more than 1e-4 (Jakob-Hanika's sigmoids are fitted, not solved).
TEST(MethodTable, ExactFlagMatchesTheBuiltMethod) {
    std::vector<float> r, g, b;
    for (int i = 0; i < 9; ++i)
        for (int j = 0; j < 9; ++j)
            for (int k = 0; k < 9; ++k) {
                r.push_back(static_cast<float>(srgb_decode(i / 8.0)));
                g.push_back(static_cast<float>(srgb_decode(j / 8.0)));
                b.push_back(static_cast<float>(srgb_decode(k / 8.0)));
            }
    for (const auto& row : method_table()) {
        const MethodSpec s = spec_for(row);
        const MethodResult made = make_method(s);
        const Colorimetry c = Colorimetry::make(load_observer(kData, s.fit.observer),
                                                load_illuminant(kData, s.fit.illuminant),
                                                s.fit.grid, primaries_by_name(s.fit.primaries));
        const Eigen::Matrix3Xd R = c.rgb_weights();
        const std::vector<float> out = expand(*made.method, r, g, b);
        const size_t n = r.size();
        double worst = 0;
        for (size_t i = 0; i < n; ++i) {
            Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
            for (Eigen::Index k = 0; k < R.cols(); ++k)
                rgb += R.col(k) * double(out[static_cast<size_t>(k) * n + i]);
            worst = std::max(
                {worst, std::abs(rgb[0] - r[i]), std::abs(rgb[1] - g[i]), std::abs(rgb[2] - b[i])});
        }
        if (row.exact)
            EXPECT_LT(worst, 1e-5) << row.name;
        else
            EXPECT_GT(worst, 1e-4) << row.name;
    }
}

// A row with a table is refused over the limit, naming its own option; a row without has no cost.
TEST(MethodTable, TableCostNamesTheRowsOption) {
    for (const auto& row : method_table()) {
        MethodSpec s = spec_for(row);
        if (row.table_option.empty()) {
            EXPECT_EQ(method_table_samples(s, 4701), 0u) << row.name;
            continue;
        }
        EXPECT_EQ(method_table_samples(s, 41),
                  uint64_t(row.table_axis(s)) * row.table_axis(s) * row.table_axis(s) * 41);
        try {
            check_method_cost(s, uint64_t(1) << 27, "many bins");
            ADD_FAILURE() << row.name << ": no limit";
        } catch (const LimitError& e) {
            EXPECT_EQ(std::string(e.what()).rfind(row.table_option + ": ", 0), 0u) << e.what();
        }
    }
}

// The measured prior's table is part of the method: another table (a retrained prior, a data
// folder of the user's) gives another recipe and cache key, so --update rebakes and no cache
// serves the old lattice; the other priors' recipes carry nothing of it.
TEST(MethodTable, TheMeasuredPriorsTableIsInItsRecipe) {
    spectex_test::TempDir dir;
    std::filesystem::create_directories(dir / "spectral");
    for (const char* f : {"observer_cie1931-2.csv", "illuminant_D65.csv"})
        std::filesystem::copy_file(kData + "/spectral/" + f, dir / ("spectral/" + std::string(f)));
    {
        std::ifstream in(kData + "/spectral/vertex_prior_measured.csv");
        std::ofstream out(dir / "spectral/vertex_prior_measured.csv");
        std::string line;
        bool changed = false;
        while (std::getline(in, line)) {
            if (!changed && line.rfind("400,", 0) == 0) {  // one value moved by 0.01
                const size_t comma = line.find(',');
                const size_t next = line.find(',', comma + 1);  // the columns after it stay
                line = "400," + std::to_string(std::stod(line.substr(comma + 1)) + 0.01) +
                       (next == std::string::npos ? "" : line.substr(next));
                changed = true;
            }
            out << line << "\n";
        }
        ASSERT_TRUE(changed);
    }
    MethodSpec a = spec_for(*find_method("lattice"));
    a.vertex_prior = "measured";
    MethodSpec b = a;
    b.fit.data_dir = dir.path;
    EXPECT_NE(vertex_prior_data(a), "");
    EXPECT_NE(vertex_prior_data(a), vertex_prior_data(b));
    EXPECT_NE(method_row(a.kind).recipe(a), method_row(b.kind).recipe(b));
    EXPECT_NE(method_cache_key(a), method_cache_key(b));
    MethodSpec c = a;
    c.vertex_prior = "lhtss";
    EXPECT_EQ(vertex_prior_data(c), "");
    MethodSpec d = c;
    d.fit.data_dir = dir.path;
    EXPECT_EQ(method_cache_key(c), method_cache_key(d));
}

}  // namespace
}  // namespace spectex
