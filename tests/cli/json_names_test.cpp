// Every JSON document spectex writes stays valid JSON (a strict parser reads
// it) when a file name is not UTF-8 — here a Latin-1 'é' (0xe9) and a control character (0x01),
// both possible in a Linux file name — and "<field>_bytes_hex" gives the exact bytes back.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;
using nlohmann::json;

namespace {

const std::string kReplacement = "\xef\xbf\xbd";  // U+FFFD

void write_png(const std::string& path) {
    std::vector<unsigned char> px(8 * 4 * 3);
    for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<unsigned char>((i * 37) % 256);
    write_image(path, 8, 4, 3, OIIO::TypeDesc::UINT8, px.data());
}

// Each line of a JSON Lines text, parsed strictly (nlohmann refuses invalid UTF-8 and lone
// surrogates); a line that does not parse fails the test with the line.
std::vector<json> parse_lines(const std::string& text) {
    std::vector<json> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        try {
            out.push_back(json::parse(line));
        } catch (const json::exception& e) {
            ADD_FAILURE() << e.what() << ": " << line;
        }
    }
    return out;
}

// What a script does with a "<field>_bytes_hex": bytes.fromhex().
std::string from_hex(const json& hex) {
    const std::string h = hex.get<std::string>();
    EXPECT_EQ(h.size() % 2, 0u) << h;
    std::string out;
    for (size_t i = 0; i + 1 < h.size(); i += 2)
        out += static_cast<char>(std::stoi(h.substr(i, 2), nullptr, 16));
    return out;
}

// The field holds the name with U+FFFD for the Latin-1 byte (the control character is a valid,
// escaped character), and the sibling field the exact bytes.
void expect_name(const json& object, const std::string& field, const std::string& bytes) {
    ASSERT_TRUE(object.contains(field + "_bytes_hex")) << field << " in " << object.dump();
    EXPECT_EQ(from_hex(object[field + "_bytes_hex"]), bytes) << field;
    std::string shown = bytes;
    for (size_t at; (at = shown.find('\xe9')) != std::string::npos;)
        shown.replace(at, 1, kReplacement);
    EXPECT_EQ(object[field].get<std::string>(), shown) << field;
}

bool has_bytes_hex_field(const json& j) {
    for (const auto& item : j.items())
        if (item.key().find("_bytes_hex") != std::string::npos) return true;
    return false;
}

}  // namespace

TEST(JsonNames, BakeReportOfALatin1NameParsesAndGivesTheNameBack) {
    ScratchDir d;
    const std::string odd = d / "caf\xe9\x01.png", plain = d / "plain.png",
                      missing = d / "gone\xe9.png";
    write_png(odd);
    write_png(plain);
    for (const bool to_file : {false, true}) {
        const std::string report = d / "report.jsonl";
        RunResult r = run_spectex({"bake", odd, plain, missing, "--output-dir", d / "out", "--json",
                                   to_file ? report : "-", "-q", "--force"});
        EXPECT_EQ(r.status, 1) << r.err;  // the missing file fails, the others are baked
        const std::string text = to_file ? read_file(report) : r.out;
        EXPECT_EQ(text.find('\xe9'), std::string::npos) << "raw Latin-1 bytes in the JSON";
        const std::vector<json> lines = parse_lines(text);
        ASSERT_EQ(lines.size(), 3u) << text;
        for (const auto& j : lines) {
            EXPECT_EQ(j["schema_version"], 2);
            const std::string input = j.contains("input_bytes_hex") ? from_hex(j["input_bytes_hex"])
                                                                    : j["input"].get<std::string>();
            if (input == odd) {
                EXPECT_EQ(j["status"], "ok") << j.dump();
                expect_name(j, "input", odd);
                expect_name(j, "output", d / "out/caf\xe9\x01.exr");
                EXPECT_TRUE(file_exists(from_hex(j["output_bytes_hex"])));
                EXPECT_TRUE(j["error"].is_null());
            } else if (input == missing) {
                EXPECT_EQ(j["status"], "failed") << j.dump();
                expect_name(j, "input", missing);
                ASSERT_TRUE(j.contains("error_bytes_hex")) << j.dump();
                EXPECT_NE(from_hex(j["error_bytes_hex"]).find(missing), std::string::npos)
                    << j.dump();
            } else {
                EXPECT_EQ(input, plain);
                EXPECT_FALSE(has_bytes_hex_field(j))
                    << "only for names that are not UTF-8: " << j.dump();
            }
        }
    }
}

TEST(JsonNames, InfoVerifyAndSampleOfALatin1NameParseAndGiveTheNameBack) {
    ScratchDir d;
    const std::string png = d / "caf\xe9\x01.png", exr = d / "caf\xe9\x01.exr";
    write_png(png);
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);

    RunResult info = run_spectex({"info", "--json", exr});
    ASSERT_EQ(info.status, 0) << info.err;
    std::vector<json> lines = parse_lines(info.out);
    ASSERT_EQ(lines.size(), 1u) << info.out;
    expect_name(lines[0], "file", exr);
    // Header text holds the name too: spectex:source records the source's path.
    bool source_seen = false;
    for (const auto& a : lines[0]["attributes"]) {
        if (a["name"] != "spectex:source") continue;
        source_seen = true;
        ASSERT_TRUE(a.contains("value_bytes_hex")) << a.dump();
        const std::string value = from_hex(a["value_bytes_hex"]);
        EXPECT_EQ(value.substr(value.size() - std::string("caf\xe9\x01.png").size()),
                  "caf\xe9\x01.png")
            << value;
    }
    EXPECT_TRUE(source_seen) << info.out;

    RunResult verify = run_spectex({"verify", exr, "--source", png, "--json", "-"});
    ASSERT_EQ(verify.status, 0) << verify.err;
    lines = parse_lines(verify.out);
    ASSERT_EQ(lines.size(), 1u) << verify.out;
    expect_name(lines[0], "file", exr);
    expect_name(lines[0]["source"], "file", png);
    EXPECT_EQ(lines[0]["passed"], true);

    // A file that cannot be read: its error names it, in the error line's every text field.
    const std::string gone = d / "gone\xe9.exr";
    RunResult missing = run_spectex({"verify", gone, "--json", "-"});
    EXPECT_EQ(missing.status, 1);
    lines = parse_lines(missing.out);
    ASSERT_EQ(lines.size(), 1u) << missing.out;
    expect_name(lines[0], "file", gone);
    ASSERT_TRUE(lines[0].contains("error_bytes_hex")) << missing.out;
    EXPECT_NE(from_hex(lines[0]["error_bytes_hex"]).find(gone), std::string::npos);
    ASSERT_TRUE(lines[0].contains("failures_bytes_hex")) << missing.out;
    EXPECT_EQ(from_hex(lines[0]["failures_bytes_hex"][0]), from_hex(lines[0]["error_bytes_hex"]));

    RunResult sample = run_spectex({"sample", exr, "1,1", "--json"});
    ASSERT_EQ(sample.status, 0) << sample.err;
    lines = parse_lines(sample.out);
    ASSERT_EQ(lines.size(), 1u) << sample.out;
    expect_name(lines[0], "file", exr);
}

TEST(JsonNames, PlanOfALightTableWithALatin1NameParses) {
    ScratchDir d;
    const std::string light = d / "lamp\xe9.csv";
    std::ofstream(light) << "wavelength,value\n360,1\n830,1\n";
    // The basis: the default's method would choose bits for the light (whole-cube passes).
    RunResult r =
        run_spectex({"plan", "--method", "basis", "--lights", light, "--grids", "380:780:20",
                     "--colours", "sample", "--max-de", "100", "--json", "-"});
    ASSERT_EQ(r.status, 0) << r.err;
    const std::vector<json> lines = parse_lines(r.out);
    ASSERT_EQ(lines.size(), 1u) << r.out;
    ASSERT_TRUE(lines[0].contains("lights_bytes_hex")) << r.out;
    const std::string name = from_hex(lines[0]["lights_bytes_hex"][0]);
    EXPECT_NE(name.find("lamp\xe9"), std::string::npos) << name;
    EXPECT_EQ(lines[0]["grids"][0]["wavelengths"][0], 380);
}

TEST(JsonNames, BakeRecordsShowStrayBytesAsReplacementCharacters) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 16, 8);
    const std::string odd = d / "odd\xff\xfe.png";
    ASSERT_EQ(std::rename(png.c_str(), odd.c_str()), 0);
    RunResult r = run_spectex({"bake", odd, "--output-dir", d / "out", "--json", "-", "-q"});
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_FALSE(has_text(r.out, "\xff")) << "raw bytes in the JSON";
    // U+FFFD for each stray byte (valid for every JSON parser), the exact bytes in hex beside it
    // (the tests above parse the records); schema 1's \udcXX was refused by strict parsers.
    EXPECT_TRUE(has_text(r.out, "odd\xef\xbf\xbd\xef\xbf\xbd.png\",\"input_bytes_hex\":\""))
        << r.out;
    EXPECT_TRUE(has_text(r.out, "6f6464fffe2e706e67\",\"output\":"))
        << r.out;  // ...o d d 0xff 0xfe . p n g
    // A valid UTF-8 name passes as it is.
    const std::string ok = d / "caf\xc3\xa9.png";
    ASSERT_EQ(std::rename(odd.c_str(), ok.c_str()), 0);
    RunResult u =
        run_spectex({"bake", ok, "--output-dir", d / "out", "--json", "-", "-q", "--force"});
    EXPECT_TRUE(has_text(u.out, "caf\xc3\xa9.png")) << u.out;
}

// One convention for --json across commands: --json FILE, '-' for standard output, as plan,
// verify and bake take it. info and sample, where --json was a flag, still take it alone (old
// scripts) and take a FILE when it ends in .json or .jsonl or is given as --json=FILE; the file
// holds what standard output would, is written atomically, and is never one of the inputs.
TEST(JsonNames, EveryCommandTakesAFileOrADash) {
    ScratchDir d;
    write_png(d / "in.png");
    const std::string exr = d / "in.exr";
    ASSERT_EQ(run_spectex({"bake", d / "in.png", "-o", exr, "-q"}).status, 0);
    struct Command {
        std::vector<std::string> args;
    };
    for (const auto& c : std::vector<Command>{{{"info", exr}}, {{"sample", exr, "1,1"}}}) {
        auto with = [&](std::vector<std::string> extra) {
            std::vector<std::string> a = c.args;
            a.insert(a.end(), extra.begin(), extra.end());
            return run_spectex(a);
        };
        const RunResult bare = with({"--json"});
        ASSERT_EQ(bare.status, 0) << bare.err;
        ASSERT_EQ(parse_lines(bare.out).size(), 1u) << bare.out;
        const RunResult dash = with({"--json", "-"});
        EXPECT_EQ(dash.out, bare.out);
        const std::string file = d / (c.args[0] + ".json"), other = d / (c.args[0] + ".txt");
        const RunResult to_file = with({"--json", file});
        ASSERT_EQ(to_file.status, 0) << to_file.err;
        EXPECT_EQ(to_file.out.find('{'), std::string::npos) << "the JSON went to the file";
        EXPECT_EQ(read_file(file), bare.out);
        ASSERT_EQ(with({"--json=" + other}).status, 0);
        EXPECT_EQ(read_file(other), bare.out);
        // Never an input: refused before any work, the input untouched.
        const std::string before = read_file(exr);
        const RunResult onto = with({"--json=" + exr});
        EXPECT_EQ(onto.status, 2) << onto.err;
        EXPECT_EQ(read_file(exr), before);
        // A FILE without the suffix is read as an argument: the error that follows says why,
        // and nothing is written under its name.
        const std::string txt = d / (c.args[0] + "_out.txt");
        const RunResult declined = with({"--json", txt});
        EXPECT_NE(declined.status, 0) << declined.err;
        EXPECT_NE(declined.err.find("it followed --json, which takes a FILE only when it ends in "
                                    ".json or .jsonl or is given as --json=FILE"),
                  std::string::npos)
            << declined.err;
        EXPECT_FALSE(file_exists(txt));
        // The hint is for that argument only: another missing input gets none.
        const RunResult missing = with({"--json", "-", d / "missing.exr"});
        EXPECT_NE(missing.status, 0);
        EXPECT_EQ(missing.err.find("it followed --json"), std::string::npos) << missing.err;
    }
    // The commands that always took a value take '-' and a file alike.
    const RunResult plan =
        run_spectex({"plan", "--method", "basis", "--lights", "D65", "--grids", "380:780:20",
                     "--colours", "sample", "--max-de", "100", "--json", "-"});
    ASSERT_EQ(plan.status, 0) << plan.err;
    EXPECT_FALSE(parse_lines(plan.out).empty());
    const RunResult verify = run_spectex({"verify", exr, "--json", d / "verify.json"});
    EXPECT_EQ(verify.status, 0) << verify.err;
    EXPECT_EQ(parse_lines(read_file(d / "verify.json")).size(), 1u);
}
