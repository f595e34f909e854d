// Every enum's table of words (base/enum_names.h) names each value once as its first word, reads
// back every word it lists, and lists its canonical words in order; a value missing from a table
// would be written as "" into headers and JSON.
#include "base/enum_names.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "base/error.h"
#include "io/alpha_kind.h"
#include "pipeline/pixel_policy.h"
#include "spectral/basis_fit.h"
#include "spectral/grid_error.h"
#include "spectral/lattice.h"

namespace spectex {
namespace {

template <typename E, size_t N>
void expect_round_trip(const EnumNames<E, N>& names, const std::vector<E>& values,
                       const std::string& listed) {
    for (E v : values) {
        const std::string word = names.name(v);
        EXPECT_FALSE(word.empty()) << listed << ": a value without a word";
        const auto back = names.find(word);
        ASSERT_TRUE(back.has_value()) << word;
        EXPECT_TRUE(*back == v) << word;
    }
    EXPECT_EQ(names.list(), listed);
    for (const auto& [value, word] : names.rows) EXPECT_TRUE(names.find(word) == value) << word;
    EXPECT_FALSE(names.find("no-such-word").has_value());
}

TEST(EnumNames, EveryTableRoundTripsItsValues) {
    expect_round_trip(kFitObjectiveNames, {FitObjective::Norm, FitObjective::Smooth},
                      "norm, smooth");
    expect_round_trip(kReconstructionNames,
                      {Reconstruction::Linear, Reconstruction::Nearest, Reconstruction::Box},
                      "linear, nearest, box");
    expect_round_trip(kVertexPriorNames,
                      {VertexPrior::JakobHanika, VertexPrior::Smooth, VertexPrior::Blend,
                       VertexPrior::Lhtss, VertexPrior::Measured},
                      "jakob-hanika, smooth, blend, lhtss, measured");
    expect_round_trip(kAlphaKindNames,
                      {AlphaKind::None, AlphaKind::Associated, AlphaKind::Unassociated},
                      "none, associated, unassociated");
    expect_round_trip(kRangePolicyNames,
                      {RangePolicy::Clamp, RangePolicy::Keep, RangePolicy::Error},
                      "clamp, keep, error");
    expect_round_trip(kNanPolicyNames, {NanPolicy::Replace, NanPolicy::Error}, "replace, error");
}

// Other spellings read as their value but are neither written nor listed.
TEST(EnumNames, OtherSpellingsAreReadNotWritten) {
    EXPECT_TRUE(kVertexPriorNames.find("jh") == VertexPrior::JakobHanika);
    EXPECT_STREQ(kVertexPriorNames.name(VertexPrior::JakobHanika), "jakob-hanika");
    EXPECT_EQ(kVertexPriorNames.list(", ", " or "),
              "jakob-hanika, smooth, blend, lhtss or measured");
    EXPECT_EQ(parse_vertex_prior("JH"), VertexPrior::JakobHanika);  // any case, as before
    EXPECT_THROW(parse_vertex_prior("sigmoid"), Error);
}

}  // namespace
}  // namespace spectex
