// The spectex:* header attributes a bake writes are exactly the keys of
// src/io/provenance_keys.h: none written under a name the readers (info, verify, --update) do
// not know, and no constant that no bake writes.
#include "io/provenance_keys.h"

#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;
namespace key = spectex::provenance_key;

namespace {

std::set<std::string> spectex_attributes(const std::string& path) {
    Imf::InputFile in(path.c_str());
    std::set<std::string> names;
    for (auto it = in.header().begin(); it != in.header().end(); ++it)
        if (std::string(it.name()).rfind(key::kPrefix, 0) == 0) names.insert(it.name());
    return names;
}

}  // namespace

TEST(ProvenanceKeys, EveryKeyABakeWritesIsAConstant) {
    ScratchDir d;
    const std::vector<uint8_t> px = {255, 0,   0, 255, 0,  255, 0,  128, 0,
                                     0,   255, 0, 128, 64, 32,  200};  // RGBA: spectex:alpha too
    write_image(d / "in.png", 2, 2, 4, OIIO::TypeDesc::UINT8, px.data());
    // Each method, a grid chosen by --wavelengths auto (the plan's keys), and a lossy compression
    // accepted with --allow-lossy (spectex:lossyCompression, written only then), and the bits of
    // --precision auto: the default's, whose answer ships with spectex (a budget of the test's own
    // would check every 8-bit colour several times, minutes under the sanitizers).
    const std::vector<std::vector<std::string>> bakes = {
        {"--method", "basis"},
        {"--method", "lattice", "--lattice-size", "3", "--compression", "b44", "--allow-lossy"},
        {"--method", "jakob-hanika", "--jh-resolution", "4"},
        {"--wavelengths", "auto", "--lights", "D65", "--grids", "380:780:20", "--max-de", "5",
         "--precision", "full"},
        {"--precision", "auto"},  // spectex:precision*
    };
    const std::set<std::string> known(std::begin(key::kAll), std::end(key::kAll));
    EXPECT_EQ(known.size(), std::size(key::kAll)) << "a key is listed twice in kAll";
    std::set<std::string> written;
    for (size_t i = 0; i < bakes.size(); ++i) {
        const std::string out = d / ("out" + std::to_string(i) + ".exr");
        std::vector<std::string> args = {"bake", d / "in.png", "-o", out};
        args.insert(args.end(), bakes[i].begin(), bakes[i].end());
        const RunResult r = run_spectex(args);
        ASSERT_EQ(r.status, 0) << r.err;
        for (const std::string& name : spectex_attributes(out)) {
            EXPECT_EQ(known.count(name), 1u)
                << name << " is written but is not in src/io/provenance_keys.h";
            written.insert(name);
        }
        // Only the lossy bake (the second) records a lossy compression.
        EXPECT_EQ(spectex_attributes(out).count(key::kLossyCompression), i == 1 ? 1u : 0u) << i;
    }
    // planGrids needs --nonuniform, whose search takes about 30 CPU-s (plan_test.cpp, PlanSlow).
    for (const std::string& k : known)
        if (k != key::kPlanGrids)
            EXPECT_EQ(written.count(k), 1u) << k << " is a key no bake here wrote";
}
