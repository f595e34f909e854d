// The bounded reader: regular files only, of bounded size, checked before reading; never blocks.
#include "base/bounded_read.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <string>

#include "base/csv_table.h"
#include "base/error.h"
#include "spectral/wavelength_grid.h"
#include "temp_dir.h"

using namespace spectex;
using spectex_test::TempDir;

namespace {

std::string error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

}  // namespace

TEST(BoundedRead, ReadsARegularFile) {
    TempDir d;
    std::ofstream(d / "a.txt") << "hello\n";
    EXPECT_EQ(read_file_bounded(d / "a.txt", 100, "a test file"), "hello\n");
    EXPECT_EQ(read_file_bounded(d / "a.txt", 6, "a test file"),
              "hello\n");  // the limit is inclusive
}

TEST(BoundedRead, RefusesWhatIsNotARegularFile) {
    TempDir d;
    ASSERT_EQ(::mkfifo((d / "fifo").c_str(), 0644), 0);
    ::mkdir((d / "dir").c_str(), 0755);
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_EQ(error_of([&] { read_file_bounded("/dev/zero", 100, "a test file"); }),
              "/dev/zero: a test file must be a regular file, not a character device");
    EXPECT_EQ(error_of([&] { read_file_bounded(d / "fifo", 100, "a test file"); }),
              d / "fifo" + ": a test file must be a regular file, not a FIFO (named pipe)");
    EXPECT_EQ(error_of([&] { check_regular_file(d / "dir", 100, "a test file"); }),
              d / "dir" + ": is a directory, not a test file");
    EXPECT_EQ(error_of([&] { read_file_bounded(d / "missing", 100, "a test file"); }),
              d / "missing" + ": No such file or directory");
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
}

TEST(BoundedRead, RefusesFilesOverTheLimitFromTheirSize) {
    TempDir d;
    std::ofstream(d / "a.txt") << std::string(101, 'x');
    EXPECT_EQ(error_of([&] { read_file_bounded(d / "a.txt", 100, "a test file"); }),
              d / "a.txt" + ": 101 bytes is over the 100 bytes limit for a test file");
    // A sparse 5 GiB file: refused from fstat, not read.
    int fd = ::open((d / "big").c_str(), O_WRONLY | O_CREAT, 0644);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::ftruncate(fd, off_t{5} << 30), 0);
    ::close(fd);
    EXPECT_EQ(
        error_of([&] { read_file_bounded(d / "big", file_limits::kOcioConfig, "an OCIO config"); }),
        d / "big" + ": 5 GiB is over the 64 MiB limit for an OCIO config");
}

TEST(BoundedRead, ProcFilesAreReadUpToTheLimit) {
    // Regular files that stat as 0 bytes: read in blocks, still bounded.
    std::string s = read_file_bounded("/proc/self/status", 1 << 20, "a test file");
    EXPECT_NE(s.find("Name:"), std::string::npos);
    EXPECT_NE(error_of([&] {
                  read_file_bounded("/proc/self/status", 10, "a test file");
              }).find("grew past the 10 bytes"),
              std::string::npos);
}

TEST(BoundedRead, FormatBytes) {
    EXPECT_EQ(format_bytes(0), "0 bytes");
    EXPECT_EQ(format_bytes(1023), "1023 bytes");
    EXPECT_EQ(format_bytes(1024), "1 KiB");
    EXPECT_EQ(format_bytes(uint64_t{64} << 20), "64 MiB");
    EXPECT_EQ(format_bytes((uint64_t{3} << 30) / 2), "1.5 GiB");
}

TEST(BoundedRead, TablesAndWavelengthFilesUseIt) {
    TempDir d;
    ASSERT_EQ(::mkfifo((d / "fifo").c_str(), 0644), 0);
    EXPECT_EQ(error_of([&] { read_csv_table(d / "fifo"); }),
              d / "fifo" + ": a spectral table must be a regular file, not a FIFO (named pipe)");
    EXPECT_EQ(error_of([&] { WavelengthGrid::from_file("/dev/zero"); }),
              "/dev/zero: a wavelength file must be a regular file, not a character device");
    // A binary line is quoted escaped and short, on one line.
    std::ofstream(d / "w.txt") << "500\n" << std::string("\x01\x02\r\n", 4) << "\n";
    std::string e = error_of([&] { WavelengthGrid::from_file(d / "w.txt"); });
    EXPECT_EQ(e, d / "w.txt" + ":2: not a wavelength: '\\x01\\x02'");
}
