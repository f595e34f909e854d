// verify's JSON record (pipeline/verify_json), built from reports made here: the schema's fields
// and their order for scripts, the result word ("ok", "failed", "stale"), null where there is no
// source, and a file name that is not UTF-8 kept exactly in file_bytes_hex.
#include "pipeline/verify_json.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline/verify.h"

using namespace spectex;

namespace {

nlohmann::ordered_json parse_line(const std::string& line) {
    EXPECT_FALSE(line.empty());
    EXPECT_EQ(line.back(), '\n');
    EXPECT_EQ(line.find('\n'), line.size() - 1) << "one record, one line";
    return nlohmann::ordered_json::parse(line);
}

}  // namespace

TEST(VerifyJson, RecordWithoutSource) {
    VerifyReport r;
    r.file = "caf\xe9.exr";
    r.width = 4;
    r.height = 2;
    r.pixels = 8;
    r.bins = 3;
    r.samples = 24;
    r.below_zero = 6;
    r.sample_type = "half";
    const auto j = parse_line(verify_json(r, VerifyGates{}, {}));
    EXPECT_EQ(j.begin().key(), "schema_version");
    EXPECT_EQ(j["schema_version"], 2);
    EXPECT_EQ(j["file"], "caf\xef\xbf\xbd.exr");
    EXPECT_EQ(j["file_bytes_hex"], "636166e92e657872");
    EXPECT_EQ(j["outside_unit_interval"]["count"], 6);
    EXPECT_DOUBLE_EQ(j["outside_unit_interval"]["share"].get<double>(), 0.25);
    EXPECT_TRUE(j["source"].is_null());
    EXPECT_TRUE(j["source_changed"].is_null());
    EXPECT_TRUE(j["thresholds"]["max_de"].is_null());
    EXPECT_EQ(j["result"], "ok");
    EXPECT_EQ(j["passed"], true);
}

TEST(VerifyJson, ResultWordsAndSource) {
    VerifyReport r;
    r.file = "a.exr";
    r.compared = true;
    r.source = "a.png";
    r.code_match_available = false;
    r.code_match_note = "float source: no codes to match";
    VerifyGates g;
    g.de = true;
    g.max_de = 0.25;
    auto j = parse_line(verify_json(r, g, {"CIEDE2000 max 0.3 > 0.25"}));
    EXPECT_EQ(j["result"], "failed");
    EXPECT_EQ(j["source"]["file"], "a.png");
    EXPECT_TRUE(j["source"]["code_match"]["share"].is_null());
    EXPECT_EQ(j["source"]["code_match"]["note"], "float source: no codes to match");
    EXPECT_DOUBLE_EQ(j["thresholds"]["max_de"].get<double>(), 0.25);
    // The pixels bake's policies would clamp, and the farthest outside [0, 1] one was, side by
    // side.
    r.source_clamped = 3;
    r.source_clamped_excursion = 0.25f;
    j = parse_line(verify_json(r, g, {}));
    auto clamped = j["source"].find("clamped_pixels");
    ASSERT_NE(clamped, j["source"].end());
    EXPECT_EQ(*clamped, 3);
    EXPECT_EQ((++clamped).key(), "clamped_excursion");
    EXPECT_EQ(*clamped, 0.25);

    VerifyReport s;
    s.file = "b.exr";
    s.source_changed = true;
    s.change.file = "b.png";
    s.change.why = "same size, other bytes";
    j = parse_line(verify_json(s, VerifyGates{}, {stale_failure(s)}));
    EXPECT_EQ(j["result"], "stale");
    EXPECT_EQ(j["source_changed"]["file"], "b.png");
    EXPECT_TRUE(j["source_changed"]["hash"].is_null());
}

TEST(VerifyJson, ErrorRecord) {
    const auto j =
        parse_line(verify_error_json("c.exr", "c.exr: not an OpenEXR file", {"a warning"}));
    EXPECT_EQ(j["file"], "c.exr");
    EXPECT_EQ(j["error"], "c.exr: not an OpenEXR file");
    EXPECT_EQ(j["failures"], nlohmann::ordered_json::array({"c.exr: not an OpenEXR file"}));
    EXPECT_EQ(j["warnings"], nlohmann::ordered_json::array({"a warning"}));
    EXPECT_EQ(j["passed"], false);
}
