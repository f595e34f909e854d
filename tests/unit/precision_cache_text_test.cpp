// The precision cache's entries as text: only a whole, valid body for the request is an answer,
// and the seal tells a damaged entry from the stored one. The end-to-end tests of damaged entries
// (tests/cli/precision_cache_test.cpp) choose the bits again for each case, several passes over
// the whole 8-bit cube, so they are Slow; this runs the parser itself under the sanitizers.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "pipeline/cached_answer.h"
#include "pipeline/plan_cache.h"
#include "spectral/basis_fit.h"
#include "spectral/colorimetry.h"

using namespace spectex;

namespace {

const std::string kDir = SPECTEX_TEST_DATA_DIR;

}  // namespace

TEST(PrecisionCacheText, OnlyAWholeValidBodyForTheRequestIsAnAnswer) {
    const Colorimetry col =
        Colorimetry::make(load_observer(kDir, "cie1931-2"), load_illuminant(kDir, "D65"),
                          WavelengthGrid::parse("400:700:20"), primaries_by_name("srgb"));
    const auto method =
        std::make_unique<BasisMethod>(fit_basis({col, FitObjective::Smooth, false}).basis, "test");
    PrecisionRequest req;
    req.method = method.get();
    req.observer = load_observer(kDir, "cie1931-2");
    for (const char* l : {"D65", "A"}) req.lights.push_back(load_illuminant(kDir, l));
    PrecisionChoice c;
    c.bits.assign(static_cast<size_t>(method->bins()), 6);
    c.light = {"D65", "A"};
    c.worst_de = {0.125, 0.25};
    c.colours = size_t(1) << 24;
    c.evaluations = 7;
    const std::string key = precision_answer_key(req);
    const std::string text = precision_cache_text(key, c);
    PrecisionChoice out;
    ASSERT_TRUE(parse_precision_cache_text(text, key, req, &out)) << text;
    EXPECT_EQ(out.bits, c.bits);
    EXPECT_EQ(out.worst_de, c.worst_de);
    // Every truncation but the last newline's is no answer.
    for (size_t n = 0; n + 1 < text.size(); ++n)
        EXPECT_FALSE(parse_precision_cache_text(text.substr(0, n), key, req, &out)) << n;
    auto replaced = [&](const std::string& from, const std::string& to) {
        std::string t = text;
        const size_t at = t.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        return at == std::string::npos ? t : t.replace(at, from.size(), to);
    };
    // Bits below the floor or above 10, a bin too few, another key, lights in another order.
    EXPECT_FALSE(parse_precision_cache_text(replaced(" 6 6", " 3 6"), key, req, &out));
    EXPECT_FALSE(parse_precision_cache_text(replaced(" 6 6", " 11 6"), key, req, &out));
    EXPECT_FALSE(parse_precision_cache_text(replaced(" 6 6", " 6"), key, req, &out));
    EXPECT_FALSE(
        parse_precision_cache_text(text, "precision-00000000000000000000000000000000", req, &out));
    std::swap(req.lights[0], req.lights[1]);
    EXPECT_FALSE(parse_precision_cache_text(text, key, req, &out));
    std::swap(req.lights[0], req.lights[1]);
    // The seal: the stored body comes back; one byte changed anywhere does not.
    const std::string sealed = sealed_entry(text);
    std::string body;
    ASSERT_TRUE(unseal_entry(sealed, &body));
    EXPECT_EQ(body, text);
    for (size_t i = 0; i < sealed.size(); i += 7) {
        std::string damaged = sealed;
        damaged[i] = static_cast<char>(damaged[i] ^ 1);
        EXPECT_FALSE(unseal_entry(damaged, &body) && body == text) << i;
    }
}
