#include "pipeline/json_text.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "base/text.h"
#include "pipeline/batch_files.h"

using namespace spectex;

namespace {

// Every report line must parse with a strict parser (nlohmann's refuses invalid UTF-8 and lone
// surrogates such as the \udcXX that schema 1 of the bake report wrote).
Json parse_line(const std::string& line) {
    EXPECT_FALSE(line.empty());
    EXPECT_EQ(line.back(), '\n');
    EXPECT_EQ(line.find('\n'), line.size() - 1) << "one line";
    return Json::parse(line);
}

}  // namespace

TEST(Utf8, SequenceLengthAcceptsWellFormedSequencesOnly) {
    struct Case {
        std::string bytes;
        size_t length;  // at index 0
    };
    const std::vector<Case> cases = {
        {"a", 1},
        {std::string(1, '\0'), 1},  // NUL is ASCII (JSON escapes it)
        {"\x7f", 1},
        {"\xc3\xa9", 2},          // é
        {"\xe2\x82\xac", 3},      // €
        {"\xf0\x9f\x98\x80", 4},  // U+1F600
        {"\xf4\x8f\xbf\xbf", 4},  // U+10FFFF, the last code point
        {"\xe9", 0},              // Latin-1 é: a lead byte without its continuation
        {"\xe9t", 0},             // ... followed by ASCII
        {"\x80", 0},              // a stray continuation byte
        {"\xff", 0},
        {"\xfe", 0},              // never in UTF-8
        {"\xc0\xaf", 0},          // overlong '/'
        {"\xe0\x80\xaf", 0},      // overlong '/' in three bytes
        {"\xed\xa0\x80", 0},      // U+D800, a UTF-16 surrogate
        {"\xed\xbf\xbf", 0},      // U+DFFF
        {"\xf4\x90\x80\x80", 0},  // U+110000, beyond Unicode
        {"\xe2\x82", 0},          // truncated
    };
    for (const auto& c : cases)
        EXPECT_EQ(utf8_sequence_length(c.bytes, 0), c.length) << bytes_hex(c.bytes);
    uint32_t cp = 0;
    ASSERT_EQ(utf8_sequence_length("x\xe2\x82\xac", 1, &cp), 3u);
    EXPECT_EQ(cp, 0x20acu);
    EXPECT_TRUE(is_valid_utf8(""));
    EXPECT_TRUE(is_valid_utf8("caf\xc3\xa9.png"));
    EXPECT_FALSE(is_valid_utf8("caf\xe9.png"));
}

TEST(JsonText, ReplacementIsOneU_FFFDPerByteThatIsNotUtf8) {
    const std::string fffd = "\xef\xbf\xbd";
    EXPECT_EQ(utf8_with_replacements("caf\xc3\xa9"), "caf\xc3\xa9");  // valid: unchanged
    EXPECT_EQ(utf8_with_replacements("caf\xe9.png"), "caf" + fffd + ".png");
    EXPECT_EQ(utf8_with_replacements("\xed\xa0\x80"), fffd + fffd + fffd);  // a surrogate: 3 bytes
    EXPECT_EQ(utf8_with_replacements("\xe2\x82x"), fffd + fffd + "x");      // truncated: 2 bytes
    EXPECT_TRUE(is_valid_utf8(utf8_with_replacements("\xff\xfe\x80\xc0\xaf")));
}

TEST(JsonText, BytesHexIsLowerCaseTwoDigitsAByte) {
    EXPECT_EQ(bytes_hex(""), "");
    EXPECT_EQ(bytes_hex("caf\xe9"), "636166e9");
    EXPECT_EQ(bytes_hex(std::string("\x00\x0a\xff", 3)), "000aff");
}

TEST(JsonText, PutTextAddsTheExactBytesOnlyWhenTheTextIsNotUtf8) {
    Json j;
    put_text(j, "input", "/tmp/caf\xc3\xa9.png");
    EXPECT_EQ(j["input"], "/tmp/caf\xc3\xa9.png");
    EXPECT_FALSE(j.contains("input_bytes_hex"));

    const std::string latin1 = "/tmp/caf\xe9\x01.png";  // a Latin-1 byte and a control character
    put_text(j, "output", latin1);
    EXPECT_EQ(j["output"], "/tmp/caf\xef\xbf\xbd\x01.png");
    ASSERT_TRUE(j.contains("output_bytes_hex"));
    EXPECT_EQ(j["output_bytes_hex"], bytes_hex(latin1));

    // The sibling follows its field, and an empty text can be null.
    put_text_or_null(j, "error", "");
    EXPECT_TRUE(j["error"].is_null());
    std::vector<std::string> keys;
    for (const auto& item : j.items()) keys.push_back(item.key());
    EXPECT_EQ(keys, (std::vector<std::string>{"input", "output", "output_bytes_hex", "error"}));
}

TEST(JsonText, ListsGetAParallelListOfBytesWhenAnyEntryIsNotUtf8) {
    Json j;
    put_texts(j, "warnings", {"fine", "bad \xff"});
    put_texts(j, "gates", {"a", "b"});
    put_texts(j, "failures", {});
    EXPECT_EQ(j["warnings"], Json({"fine", "bad \xef\xbf\xbd"}));
    EXPECT_EQ(j["warnings_bytes_hex"], Json({nullptr, bytes_hex("bad \xff")}));
    EXPECT_FALSE(j.contains("gates_bytes_hex"));
    EXPECT_TRUE(j["failures"].is_array());
    EXPECT_TRUE(j["failures"].empty());
}

TEST(JsonText, NumbersKeepThePrecisionOfTheirFormatAndIntegersStayIntegers) {
    EXPECT_EQ(json_number(380, "%.9g").dump(), "380");
    EXPECT_TRUE(json_number(380, "%.9g").is_number_integer());
    EXPECT_EQ(json_number(0.1 + 0.2, "%.9g").dump(), "0.3");
    EXPECT_EQ(json_number(1.0 / 3.0, "%.6g").dump(), "0.333333");
    EXPECT_EQ(json_number(2.5e-7, "%.9g").dump(), "2.5e-07");
    // Fixed formats keep their rounding; the trailing zeros printf wrote are not kept.
    EXPECT_EQ(json_number(1.23456, "%.3f").dump(), "1.235");
    EXPECT_EQ(json_number(1.5, "%.3f").dump(), "1.5");
    EXPECT_EQ(json_number(1.5, "%.3f").get<double>(), 1.5);
    EXPECT_TRUE(json_number(std::nan(""), "%.9g").is_null());
    EXPECT_TRUE(json_number(std::numeric_limits<double>::infinity(), "%.3f").is_null());
    EXPECT_EQ(json_number_text("383.7").dump(), "383.7");
    EXPECT_EQ(json_number_text("400").dump(), "400");
    EXPECT_THROW(json_number_text("T.400nm"), std::exception);
}

TEST(JsonText, LinesAreCompactValidJsonWhateverTheBytes) {
    Json j;
    j["schema_version"] = 1;
    put_text(j, "name", "a\"b\\c\n\t\x1b[2J\x7f");
    j["stray"] = "raw \xff";  // not through put_text: still valid JSON, as U+FFFD
    const std::string line = json_line(j);
    EXPECT_EQ(line.rfind("{\"schema_version\":1,\"name\":\"a\\\"b\\\\c\\n\\t\\u001b[2J", 0), 0u)
        << line;
    const Json back = parse_line(line);
    EXPECT_EQ(back["name"], "a\"b\\c\n\t\x1b[2J\x7f");
    EXPECT_EQ(back["stray"], "raw \xef\xbf\xbd");
}

TEST(JsonText, BakeRecordsOfNamesThatAreNotUtf8ParseAndGiveTheBytesBack) {
    FileRecord r;
    r.input = "in/caf\xe9\x07.png";
    r.output = "out/caf\xe9\x07.exr";
    r.status = BatchStatus::Failed;
    r.error = r.input + ": cannot open";
    r.result.colorspace = "sRGB - Texture";
    r.settings_hash = "fnv1a64:0123456789abcdef";
    const Json j = parse_line(json_record(r));
    EXPECT_EQ(j["schema_version"], kJsonSchemaVersion);
    EXPECT_EQ(j["input"], "in/caf\xef\xbf\xbd\x07.png");
    EXPECT_EQ(j["input_bytes_hex"], bytes_hex(r.input));
    EXPECT_EQ(j["output_bytes_hex"], bytes_hex(r.output));
    EXPECT_EQ(j["error_bytes_hex"], bytes_hex(r.error));
    EXPECT_FALSE(j.contains("colorspace_bytes_hex"));
    EXPECT_FALSE(j.contains("stages"));  // only for baked files

    r.input = "in/a.png";
    r.output = "out/a.exr";
    r.error.clear();
    r.status = BatchStatus::Ok;
    r.result.seconds = 1.5;
    r.result.stages.writer = "core";
    r.result.stages.read = 0.25;
    const std::string line = json_record(r);
    EXPECT_EQ(line.find("_bytes_hex"), std::string::npos) << line;
    EXPECT_NE(line.find("\"error\":null,\"seconds\":1.5,\"pixels\":0,"), std::string::npos) << line;
    EXPECT_NE(line.find("\"stages\":{\"writer\":\"core\",\"read_s\":0.25,\"colour_s\":0.0,"),
              std::string::npos)
        << line;
}
