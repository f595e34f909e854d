// bake's set-up (pipeline/bake_request): one request, its tables read once, the grid planned and
// the method built from the same description, the settings hash known before anything is built.
#include "pipeline/bake_request.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "base/error.h"
#include "spectral/basis.h"
#include "spectral/spectrum.h"

namespace spectex {
namespace {

const std::string kData = SPECTEX_TEST_DATA_DIR;

// What the set-up told.
struct Recorder : BakeSetupListener {
    std::vector<PlanSpec> planned;
    std::vector<MethodSpec> built;
    std::vector<WavelengthGrid> grids;
    void grid_planned(const PlanSpec& s, const PlanResult&, const PlanCacheReport&) override {
        planned.push_back(s);
    }
    void grid_known(const WavelengthGrid& g) override { grids.push_back(g); }
    void method_built(const MethodSpec& s, const MethodResult&) override { built.push_back(s); }
};

// A scratch folder, removed with what it holds.
struct Scratch {
    std::string dir;
    Scratch() {
        char tmpl[] = "/tmp/spectex-bake-request-XXXXXX";
        dir = mkdtemp(tmpl);
    }
    ~Scratch() { std::system(("rm -rf '" + dir + "'").c_str()); }
    std::string operator/(const std::string& name) const { return dir + "/" + name; }
};

BakeRequest plain_request() {
    BakeRequest r;
    r.data_dir = kData;
    r.grid = WavelengthGrid::parse("380:780:10");
    r.options.config = kData + "/spectex.ocio";
    r.no_cache = true;
    return r;
}

TEST(BakeRequest, AutoGridPlansAndBuildsTheSameJakobHanikaTable) {
    BakeRequest r = plain_request();
    r.method.kind = MethodKind::JakobHanika;
    r.method.jh_resolution = 5;  // not the default 33: a search that ignored it would measure 33^3
    r.auto_grid = true;
    r.plan.lights = {"D65", "A"};
    r.plan.max_de = 100;  // every candidate passes: the cheapest is chosen
    r.plan.candidates = {WavelengthGrid::parse("400:700:20"), WavelengthGrid::parse("380:780:50")};
    r.plan.sample_stride = 51;  // 6^3 colours: the test is about the description, not the figures
    r.plan.colours = "sample";
    const BakeSetup setup(r);
    // The hash is known before the grid is chosen: no grid, no method yet.
    EXPECT_TRUE(setup.hashed().grid.lambda.empty());
    EXPECT_EQ(setup.hashed().method, nullptr);
    EXPECT_FALSE(setup.hashed().settings_hash.empty());
    Recorder rec;
    const BakeSettings s = setup.finish(rec);
    ASSERT_EQ(rec.planned.size(), 1u);
    ASSERT_EQ(rec.built.size(), 1u);
    const MethodSpec& planned = rec.planned[0].method;
    const MethodSpec& built = rec.built[0];
    EXPECT_EQ(planned.kind, MethodKind::JakobHanika);
    EXPECT_EQ(planned.jh_resolution, 5);
    EXPECT_EQ(built.jh_resolution, 5);
    EXPECT_EQ(planned.head(), built.head());
    EXPECT_EQ(planned.fit.describe().substr(0, 30), built.fit.describe().substr(0, 30));
    // The chosen grid (380:780:50, 9 bins: fewer than 400:700:20's 16) is the output grid and the
    // built method's.
    EXPECT_EQ(s.grid.describe(), "380:780:50");
    ASSERT_EQ(rec.grids.size(), 1u);
    EXPECT_EQ(rec.grids[0].describe(), "380:780:50");
    EXPECT_EQ(built.fit.grid.describe(), "380:780:50");
    // The table baked is the one the plan describes on the chosen grid: the same build, the
    // process' memo gives the very object.
    MethodSpec again = planned;
    again.fit.grid = s.grid;
    EXPECT_EQ(make_method(again).method.get(), s.method.get());
    EXPECT_EQ(s.settings_hash, setup.hashed().settings_hash);
    EXPECT_EQ(s.plan.lights, "D65,A");
    EXPECT_FALSE(s.plan.worst_de.empty());
}

// The tables are read when the request is resolved, and never again: the files a bake reads may
// go (or change) once the set-up has read them, and every file of the batch, its colour-aware
// rounding included, is baked with what was read then.
TEST(BakeRequest, TablesAreReadOnceWhenTheRequestIsResolved) {
    Scratch d;
    const std::string light = d / "my_light.csv";
    {
        const Spectrum d65 = load_illuminant(kData, "D65");
        std::ofstream f(light);
        f << "wavelength,value\n";
        for (size_t i = 0; i < d65.lambda.size(); ++i)
            f << d65.lambda[i] << "," << d65.value[i] * (1.0 + 0.001 * (i % 7)) << "\n";
    }
    for (MethodKind kind : {MethodKind::Basis, MethodKind::Lattice}) {
        BakeRequest r = plain_request();
        r.method.kind = kind;
        r.method.lattice_size = 3;
        r.method.fit.illuminant = light;
        // A grid of its own per kind, so that no earlier build of the process is reused.
        r.grid = WavelengthGrid::parse(kind == MethodKind::Basis ? "380:780:8" : "380:780:16");
        const BakeSetup setup(r);
        ASSERT_EQ(std::rename(light.c_str(), (light + ".gone").c_str()), 0);
        Recorder rec;
        BakeSettings s;
        ASSERT_NO_THROW(s = setup.finish(rec)) << method_row(kind).name;
        ASSERT_EQ(std::rename((light + ".gone").c_str(), light.c_str()), 0);
        ASSERT_NE(s.method, nullptr);
        EXPECT_EQ(s.method->lambda(), s.grid.lambda);
        // Half's colour-aware rounding weights: computed once for the batch, per bin.
        EXPECT_EQ(s.half_rgb_weight.size(), 3 * s.grid.size());
        EXPECT_EQ(s.illuminant, light);
    }
}

TEST(BakeRequest, AGivenBasisFileIsReadOnceAndBringsItsGrid) {
    Scratch d;
    const std::string csv = d / "basis.csv";
    {
        Basis b = load_basis(kData, "mallett2019");
        std::ofstream f(csv);
        write_basis_csv(f, b);
    }
    BakeRequest r = plain_request();
    r.basis = csv;  // --basis FILE, without --wavelengths: the file's grid
    const BakeSetup setup(r);
    ASSERT_NE(setup.tables().basis, nullptr);
    const std::string checksum = setup.tables().basis->checksum();
    ASSERT_EQ(std::remove(csv.c_str()), 0);
    Recorder rec;
    const BakeSettings s = setup.finish(rec);
    EXPECT_TRUE(rec.built.empty());  // a given table is not built
    EXPECT_EQ(s.grid.lambda, setup.tables().basis->lambda);
    EXPECT_EQ(s.method->lambda(), s.grid.lambda);
    EXPECT_EQ(s.method->checksum(), BasisMethod(*setup.tables().basis, "file").checksum());
    EXPECT_FALSE(checksum.empty());
    // Given on another grid, it is refused by the set-up, naming both grids.
    BakeRequest other = plain_request();
    other.basis = "mallett2019";
    other.grid_given = true;
    other.grid = WavelengthGrid::parse("400:700:10");
    try {
        BakeSetup bad(other);
        ADD_FAILURE() << "a basis on another grid was taken";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("not on the output grid 400:700:10"),
                  std::string::npos)
            << e.what();
    }
}

TEST(BakeRequest, TheHashDependsOnWhatMakesTheFilesOnly) {
    BakeRequest r = plain_request();
    const std::string base = BakeSetup(r).hashed().settings_hash;
    EXPECT_EQ(BakeSetup(r).hashed().settings_hash, base);
    BakeRequest threads = r;
    threads.threads = 3;
    threads.no_cache = false;
    EXPECT_EQ(BakeSetup(threads).hashed().settings_hash, base);
    BakeRequest lattice = r;
    lattice.method.kind = MethodKind::Lattice;
    EXPECT_NE(BakeSetup(lattice).hashed().settings_hash, base);
    BakeRequest size = lattice;
    size.method.lattice_size = 5;
    EXPECT_NE(BakeSetup(size).hashed().settings_hash, BakeSetup(lattice).hashed().settings_hash);
    BakeRequest illuminant = r;
    illuminant.method.fit.illuminant = "A";
    EXPECT_NE(BakeSetup(illuminant).hashed().settings_hash, base);
}

}  // namespace
}  // namespace spectex
