// Outputs by identity, checked before any work: no output of a command (-o, templates,
// --output-dir, --json, basis -o) is a file the same command reads, whatever its spelling, links
// or hard links; no two outputs of a batch are one file; a template never climbs out of the folder
// it names; -o names an .exr file, templates use known tokens, grids end on a bin. Usage mistakes
// exit 2 and leave every file as it was.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "cli/cli_util.h"

using namespace spectex_test;

namespace {

bool contains(const std::string& h, const std::string& n) { return h.find(n) != std::string::npos; }

void write_png(const std::string& path, uint8_t v = 90) {
    std::vector<uint8_t> px(4 * 4 * 3, v);
    write_image(path, 4, 4, 3, OIIO::TypeDesc::UINT8, px.data());
}

std::string shipped(const std::string& name) {
    return std::string(SPECTEX_TEST_DATA_DIR) + "/" + name;
}

void copy_file(const std::string& from, const std::string& to) {
    std::ofstream(to, std::ios::binary) << read_file(from);
}

// Every stderr line is one of ours, printable, and the first names `what`.
void expect_usage_error(const RunResult& r, const std::string& what) {
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, what)) << "stderr does not mention '" << what << "':\n" << r.err;
}

// A copy of the shipped data folder, so that a broken check could only harm the copy.
std::string data_copy(const ScratchDir& d) {
    const std::string dd = d / "data";
    EXPECT_EQ(
        std::system(("cp -r '" + std::string(SPECTEX_TEST_DATA_DIR) + "' '" + dd + "'").c_str()),
        0);
    return dd;
}

void expect_unchanged(const std::string& path, const std::string& before) {
    EXPECT_EQ(read_file(path), before) << path;
}

}  // namespace

TEST(OutputIdentity, NoOutputIsAFileTheCommandReads) {
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "sub").c_str(), 0755), 0);
    ASSERT_EQ(::symlink(d.path().c_str(), (d / "link").c_str()), 0);
    const std::string in = d / "in.png";
    write_png(in);
    ASSERT_EQ(::link(in.c_str(), (d / "hard.png").c_str()), 0);
    const std::string list = d / "list.txt", config = d / "my.ocio", wl = d / "wl.txt",
                      basis = d / "b.csv";
    std::ofstream(list) << in << "\n";
    copy_file(shipped("spectex.ocio"), config);
    {
        std::ofstream w(wl);
        for (int l = 380; l <= 780; l += 5) w << l << "\n";
    }
    copy_file(shipped("spectral/basis_mallett2019.csv"), basis);
    const std::vector<std::string> files = {in, list, config, wl, basis};
    std::vector<std::string> before;
    for (const auto& f : files) before.push_back(read_file(f));

    // Each read file named as an output, spelt differently: as given, with ./ and .., through a
    // symbolic link to the folder, with a doubled slash, and (for the input) through a hard link.
    auto spellings = [&](const std::string& f) {
        const std::string base = f.substr(d.path().size() + 1);
        return std::vector<std::string>{f, d.path() + "/sub/../" + base, d.path() + "/link/" + base,
                                        d.path() + "//" + base, d.path() + "/./" + base};
    };
    for (const auto& alias : spellings(in)) {
        expect_usage_error(run_spectex({"bake", in, "-o", d / "out.exr", "--json", alias}),
                           "--json");
        expect_usage_error(run_spectex({"bake", in, "-o", alias + ".exr", "--json", alias}), "");
    }
    expect_usage_error(run_spectex({"bake", in, "-o", d / "out.exr", "--json", d / "hard.png"}),
                       "hard.png");
    for (const auto& alias : spellings(list))
        expect_usage_error(
            run_spectex({"bake", "--from-list", list, "-o", d / "o.exr", "--json", alias}),
            "--from-list");
    for (const auto& alias : spellings(config))
        expect_usage_error(
            run_spectex({"bake", in, "--config", config, "-o", d / "o.exr", "--json", alias}),
            "OCIO config");
    for (const auto& alias : spellings(wl))
        expect_usage_error(
            run_spectex({"bake", in, "--wavelengths-file", wl, "-o", d / "o.exr", "--json", alias}),
            "--wavelengths-file");
    for (const auto& alias : spellings(basis))
        expect_usage_error(
            run_spectex({"bake", in, "--basis", basis, "-o", d / "o.exr", "--json", alias}),
            "--basis");
    // $OCIO is read too.
    expect_usage_error(run_spectex({"bake", in, "-o", d / "o.exr", "--json", d / "link/my.ocio"},
                                   {"OCIO=" + config}),
                       "OCIO config");
    // An .exr input and an output spelt through the link.
    ASSERT_EQ(run_spectex({"bake", in, "-o", d / "src.exr"}).status, 0);
    const std::string exr_before = read_file(d / "src.exr");
    expect_usage_error(run_spectex({"bake", d / "src.exr", "-o", d / "link/src.exr"}), "src.exr");
    EXPECT_EQ(read_file(d / "src.exr"), exr_before);

    for (size_t i = 0; i < files.size(); ++i)
        EXPECT_EQ(read_file(files[i]), before[i]) << files[i] << " changed";
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(OutputIdentity, BasisOutputIsNeverItsObserverIlluminantOrGrid) {
    ScratchDir d;
    const std::string obs = d / "obs.csv", ill = d / "ill.csv", wl = d / "wl.txt";
    copy_file(shipped("spectral/observer_cie1931-2.csv"), obs);
    copy_file(shipped("spectral/illuminant_D65.csv"), ill);
    {
        std::ofstream w(wl);
        for (int l = 380; l <= 780; l += 10) w << l << "\n";
    }
    const std::string obs0 = read_file(obs), ill0 = read_file(ill), wl0 = read_file(wl);
    expect_usage_error(run_spectex({"basis", "-o", obs, "--observer", obs}), "--observer");
    expect_usage_error(run_spectex({"basis", "-o", d.path() + "/./obs.csv", "--observer", obs}),
                       "--observer");
    expect_usage_error(run_spectex({"basis", "-o", ill, "--illuminant", ill}), "--illuminant");
    expect_usage_error(run_spectex({"basis", "-o", wl, "--wavelengths-file", wl}),
                       "--wavelengths-file");
    EXPECT_EQ(read_file(obs), obs0);
    EXPECT_EQ(read_file(ill), ill0);
    EXPECT_EQ(read_file(wl), wl0);
    // The same tables as inputs with a different output work.
    RunResult ok =
        run_spectex({"basis", "-q", "-o", d / "b.csv", "--observer", obs, "--illuminant", ill});
    EXPECT_EQ(ok.status, 0) << ok.err;
}

TEST(OutputIdentity, TwoInputsNeverBakeIntoOneOutput) {
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "dir").c_str(), 0755), 0);
    ASSERT_EQ(::symlink((d / "dir").c_str(), (d / "alias").c_str()), 0);
    write_png(d / "dir/a.png", 40);
    write_png(d / "dir/a.tif", 200);
    const std::vector<std::vector<std::string>> pairs = {
        {d / "dir/a.png", d.path() + "/dir/../dir/a.tif"},
        {d / "dir/a.png", d.path() + "/dir//a.tif"},
        {d / "dir/a.png", d / "alias/a.tif"},
        {d / "dir/a.png", d.path() + "/./dir/a.tif"},
    };
    // Found before any work (a usage error, exit 2, nothing baked), with the way out.
    for (const auto& p : pairs) {
        ::unlink((d / "dir/a.exr").c_str());
        RunResult r = run_spectex({"bake", "-q", p[0], p[1], "-o", "{dir}/{stem}.exr"});
        EXPECT_EQ(r.status, 2) << p[1] << ": " << r.err;
        EXPECT_TRUE(contains(r.err, "would write an output another input writes")) << r.err;
        EXPECT_TRUE(contains(r.err, "--base-dir")) << r.err;
        EXPECT_FALSE(file_exists(d / "dir/a.exr")) << "work started before the check";
        EXPECT_TRUE(temp_files_in(d / "dir").empty());
    }
    // An existing hard link between two outputs is one file too.
    write_png(d / "dir/b.png", 10);
    ASSERT_EQ(run_spectex({"bake", d / "dir/a.png", "-o", d / "dir/a.exr"}).status, 0);
    ASSERT_EQ(::link((d / "dir/a.exr").c_str(), (d / "dir/b.exr").c_str()), 0);
    struct stat before;
    ASSERT_EQ(::stat((d / "dir/a.exr").c_str(), &before), 0);
    RunResult r =
        run_spectex({"bake", "-q", d / "dir/a.png", d / "dir/b.png", "-o", "{dir}/{stem}.exr"});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(contains(r.err, "would write an output another input writes")) << r.err;
    struct stat after;
    ASSERT_EQ(::stat((d / "dir/a.exr").c_str(), &after), 0);
    EXPECT_EQ(after.st_mtim.tv_nsec, before.st_mtim.tv_nsec) << "an output was rewritten";
    EXPECT_EQ(after.st_mtim.tv_sec, before.st_mtim.tv_sec);
}

TEST(OutputIdentity, ATemplateNeverClimbsOutOfItsFolder) {
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "in").c_str(), 0755), 0);
    ASSERT_EQ(::mkdir((d / "out").c_str(), 0755), 0);
    ASSERT_EQ(::mkdir((d / "out/x").c_str(), 0755), 0);
    write_png(d / "in/...png");  // stem ".."
    write_png(d / "in/..png");   // stem "."
    for (const auto& name : {"...png", "..png"}) {
        RunResult r =
            run_spectex({"bake", d.path() + "/in/" + name, "-o", d.path() + "/out/x/{stem}/y.exr"});
        expect_usage_error(r, "leave the folder");
        EXPECT_FALSE(file_exists(d / "out/y.exr")) << name;
        EXPECT_FALSE(file_exists(d / "out/x/y.exr")) << name;
    }
    // As a file name, such a stem stays inside the folder.
    RunResult ok = run_spectex({"bake", d / "in/...png", "--output-dir", d / "out"});
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_TRUE(file_exists(d / "out/...exr"));
}

TEST(OutputIdentity, OutputsAndGridsAreCheckedBeforeAnyWork) {
    ScratchDir d;
    write_png(d / "in.png");
    ASSERT_EQ(::mkdir((d / "out").c_str(), 0755), 0);
    expect_usage_error(run_spectex({"bake", d / "in.png", "-o", d / "out"}), "is a folder");
    expect_usage_error(run_spectex({"bake", d / "in.png", "-o", d.path() + "/out/"}),
                       "is a folder");
    expect_usage_error(run_spectex({"bake", d / "in.png", "-o", d / "x.png"}),
                       "does not end in .exr");
    RunResult tok = run_spectex({"bake", d / "in.png", "-o", d.path() + "/out/{name}.exr"});
    expect_usage_error(tok, "{name}");
    EXPECT_TRUE(contains(tok.err, "{dir}, {reldir}, {stem}, {ext}")) << tok.err;
    RunResult grid =
        run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--wavelengths", "400:700:7"});
    expect_usage_error(grid, "400:694:7");
    expect_usage_error(run_spectex({"basis", "-o", d / "b.csv", "--wavelengths", "380:780:30"}),
                       "380:770:30");
    expect_usage_error(run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--json", d / "out"}),
                       "is a folder");
    for (const std::string opt :
         {"--colorspace", "--config", "--json", "--basis", "--observer", "--wavelengths"})
        expect_usage_error(run_spectex({"bake", d / "in.png", "-o", d / "o.exr", opt, ""}), opt);
    for (const auto& n : list_dir(d / "out")) ADD_FAILURE() << "written into out/: " << n;
    for (const auto& n : list_dir(d.path()))
        EXPECT_TRUE(n == "in.png" || n == "out") << "written: " << n;
}

TEST(OutputIdentity, LongOutputNamesKeepTheirTemporaryWithinTheNameLimit) {
    ScratchDir d;
    write_png(d / "in.png");
    for (size_t len :
         {236u, 237u, 249u, 255u}) {  // 236 + 19 = 255: the first that needed shortening is 237
        const std::string name = std::string(len - 4, 'n') + ".exr";
        RunResult r = run_spectex({"bake", d / "in.png", "-o", d / name});
        EXPECT_EQ(r.status, 0) << len << ": " << r.err;
        EXPECT_TRUE(file_exists(d / name)) << len;
    }
    EXPECT_TRUE(temp_files_in(d.path()).empty());
    // One byte over the limit is refused before any work (exit 2), and nothing is left.
    RunResult r = run_spectex({"bake", d / "in.png", "-o", d / (std::string(252, 'n') + ".exr")});
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_TRUE(temp_files_in(d.path()).empty());
}

TEST(OutputIdentity, NoOutputIsALutFileOfTheConfig) {
    // The OCIO config reads its LUT files (FileTransform src, resolved through its search path):
    // an output may not be one of them either, however it is spelt.
    ScratchDir d;
    ASSERT_EQ(::mkdir((d / "luts").c_str(), 0755), 0);
    const std::string lut = d / "luts/curve.cube";
    std::ofstream(lut) << "LUT_1D_SIZE 2\n0 0 0\n1 1 1\n";
    const std::string cfg = d / "c.ocio";
    std::ofstream(cfg) << lut_config_text("luts", "curve.cube");
    write_png(d / "in.png");
    const std::string before = read_file(lut);
    for (const std::string& alias : {lut, d.path() + "/luts/../luts/curve.cube"}) {
        expect_usage_error(run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--config", cfg,
                                        "--colorspace", "lut_space", "--json", alias}),
                           "LUT file");
        expect_usage_error(run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--colorspace",
                                        "lut_space", "--json", alias},
                                       {"OCIO=" + cfg}),
                           "LUT file");
    }
    EXPECT_EQ(read_file(lut), before);
    RunResult ok = run_spectex({"bake", d / "in.png", "-o", d / "o.exr", "--config", cfg,
                                "--colorspace", "lut_space", "--json", d / "report.jsonl"});
    EXPECT_EQ(ok.status, 0) << ok.err;
}

TEST(OutputIdentity, TheShippedTablesAreNeverOutputs) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 16, 8), dd = data_copy(d);
    const std::vector<std::string> env = {"SPECTEX_DATA_DIR=" + dd};
    const std::string obs = dd + "/spectral/observer_cie1931-2.csv",
                      d65 = dd + "/spectral/illuminant_D65.csv",
                      mal = dd + "/spectral/basis_mallett2019.csv",
                      ill_a = dd + "/spectral/illuminant_A.csv";
    const std::string before_obs = read_file(obs), before_d65 = read_file(d65),
                      before_mal = read_file(mal), before_a = read_file(ill_a);
    const std::vector<std::vector<std::string>> cases = {
        {"bake", png, "-o", d / "a.exr", "--json", obs},
        {"bake", png, "-o", d / "a.exr", "--basis", "mallett2019", "--json", mal},
        {"bake", png, "-o", d / "a.exr", "--illuminant", "A", "--json", ill_a},
        {"basis", "-q", "-o", d65},
        {"basis", "-q", "-o", obs},
    };
    for (const auto& args : cases) {
        RunResult r = run_spectex(args, env);
        EXPECT_EQ(r.status, 2) << args[0] << " " << args.back() << ": " << r.err;
        EXPECT_TRUE(has_text(r.err, "which this command reads")) << r.err;
    }
    ASSERT_EQ(run_spectex({"bake", png, "-o", d / "z.exr", "-q"}, env).status, 0);
    RunResult v = run_spectex({"verify", d / "z.exr", "--json", d65}, env);
    EXPECT_EQ(v.status, 2) << v.err;
    RunResult pl = run_spectex({"plot", d / "z.exr", "--pixel", "0,0", "-o", obs}, env);
    EXPECT_EQ(pl.status, 2) << pl.err;
    expect_unchanged(obs, before_obs);
    expect_unchanged(d65, before_d65);
    expect_unchanged(mal, before_mal);
    expect_unchanged(ill_a, before_a);
}

TEST(OutputIdentity, VerifyNeverWritesASourceOrLutItReads) {
    ScratchDir d;
    const std::string png = pattern_png(d, "src.png", 16, 8), exr = d / "a.exr";
    ASSERT_EQ(run_spectex({"bake", png, "-o", exr, "-q"}).status, 0);
    const std::string before = read_file(png);
    RunResult r = run_spectex({"verify", exr, "--source-from-header", "--json", png});
    EXPECT_EQ(r.status, 2) << r.err;
    expect_unchanged(png, before);

    // A config whose colour space loads a LUT: neither may be verify's report.
    std::ofstream(d / "lut.spi1d")
        << "Version 1\nFrom 0.0 1.0\nLength 2\nComponents 1\n{\n0.0\n1.0\n}\n";
    const std::string cfg = d / "lut.ocio";
    std::ofstream(cfg) << lut_config_text(d.path(), "lut.spi1d");
    const std::string lin = d / "lin.exr";
    std::vector<float> px(16 * 8 * 3, 0.25f);
    write_image(lin, 16, 8, 3, OIIO::TypeDesc::FLOAT, px.data());
    const std::string baked = d / "b.exr";
    ASSERT_EQ(
        run_spectex({"bake", lin, "-o", baked, "--config", cfg, "--colorspace", "lut_space", "-q"})
            .status,
        0);
    const std::string lut_before = read_file(d / "lut.spi1d"), cfg_before = read_file(cfg);
    RunResult l =
        run_spectex({"verify", baked, "--source", lin, "--config", cfg, "--json", d / "lut.spi1d"});
    EXPECT_EQ(l.status, 2) << l.err;
    EXPECT_TRUE(has_text(l.err, "a LUT file of")) << l.err;
    // And the config the header records, when none is given.
    RunResult c = run_spectex({"verify", baked, "--source", lin, "--json", cfg});
    EXPECT_EQ(c.status, 2) << c.err;
    expect_unchanged(d / "lut.spi1d", lut_before);
    expect_unchanged(cfg, cfg_before);
}

TEST(OutputIdentity, AListRedirectedIntoStandardInputIsARead) {
    ScratchDir d;
    const std::string png = pattern_png(d, "in.png", 16, 8), list = d / "list.txt";
    std::ofstream(list) << png << "\n";
    const std::string before = read_file(list);
    RunResult b =
        run_spectex_io({"bake", "--from-list", "-", "-o", d / "z.exr", "--json", list}, list);
    EXPECT_EQ(b.status, 2) << b.err;
    EXPECT_TRUE(has_text(b.err, "standard input")) << b.err;
    expect_unchanged(list, before);
    ASSERT_EQ(run_spectex({"bake", png, "-o", d / "z.exr", "-q"}).status, 0);
    std::ofstream(list) << d / "z.exr"
                        << "\n";
    const std::string before2 = read_file(list);
    RunResult v = run_spectex_io({"verify", "--from-list", "-", "--json", list}, list);
    EXPECT_EQ(v.status, 2) << v.err;
    expect_unchanged(list, before2);
}
