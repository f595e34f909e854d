#pragma once
// Reading files that a user names, safely: only regular files, of bounded size, checked before a
// byte is read. A device (/dev/zero, /dev/urandom), a FIFO or a folder is refused at once, with
// one line "<path>: <cause>" (thrown as Error), in bounded memory; a FIFO is never opened for
// reading, so it cannot block.
//
// The check is: stat(path) (refuse anything but a regular file without opening it), then
// open(O_RDONLY | O_NONBLOCK | O_NOCTTY), then fstat(descriptor) and the same checks again, and
// the descriptor must be the file that was stat'ed (same device and inode): a path swapped for a
// FIFO or a device between the two steps is refused too. Plain POSIX: no image-library headers
// (base/, the floor every other layer stands on).
#include <sys/types.h>

#include <cstdint>
#include <string>

namespace spectex {

// Size limits, in bytes, of the files spectex reads.
// "a directory", "a character device", "a FIFO (named pipe)", ... for messages (st_mode of a stat).
const char* file_kind(mode_t st_mode);

namespace file_limits {
// Spectral tables (--basis, --observer, --illuminant CSV): kilobytes in practice (a 1 nm table of
// 4 columns is ~40 kB); 64 MiB leaves room for absurdly fine grids and long provenance comments.
constexpr uint64_t kSpectralTable = uint64_t{64} << 20;
// --wavelengths-file: at most 100000 wavelengths (the grid limit) of a few bytes each, plus
// comments: 16 MiB is ample.
constexpr uint64_t kWavelengthFile = uint64_t{16} << 20;
// --from-list: 100k paths of a few hundred bytes is ~30 MB; 256 MiB allows a million paths of
// 250 bytes. Each line is also limited to PATH_MAX.
constexpr uint64_t kInputList = uint64_t{256} << 20;
// And at most 2^20 paths a list (a 100 MB list of one-letter lines would otherwise hold 50 million
// strings, 3.7 GB): more in one call than any batch needs; split it, or shard it.
constexpr size_t kInputListEntries = size_t{1} << 20;
// OCIO configs: the ACES studio config is ~1 MB; 64 MiB for generated configs with long inline
// metadata.
constexpr uint64_t kOcioConfig = uint64_t{64} << 20;
// LUT files referenced by an OCIO config (FileTransform src): a 65^3 .cube is ~8 MB of text and a
// 129^3 one ~60 MB. OCIO parses some formats slowly (an 80 MB .spi1d took 155 s, 1.5 GB): 128 MiB
// admits every real LUT and refuses what would take minutes.
constexpr uint64_t kLutFile = uint64_t{128} << 20;
// Input images: the decoded size is bounded by --max-pixels (from the header, before any pixel
// is read); this cap only refuses absurd files (a 16384^2 image of 64 float channels is 64 GiB).
constexpr uint64_t kImage = uint64_t{64} << 30;
}  // namespace file_limits

// Whether something exists at `path` (stat(2) succeeds; links followed), for a name that is a
// file only when one exists there (--basis, --observer, --illuminant). When not, and `error` is
// given, *error is stat's errno (ENOENT, EACCES, ENOTDIR, ...).
bool path_exists(const std::string& path, int* error = nullptr);

// A readable regular file, checked as above. Owns the descriptor.
class CheckedFile {
  public:
    // `what` names the role in messages: "OCIO config", "input list", ... Throws Error.
    CheckedFile(const std::string& path, uint64_t max_bytes, const std::string& what);
    ~CheckedFile();
    CheckedFile(const CheckedFile&) = delete;
    CheckedFile& operator=(const CheckedFile&) = delete;

    int fd() const { return fd_; }
    uint64_t size() const { return size_; }  // from fstat
    const std::string& path() const { return path_; }

    // Reads the whole file; it may not grow past max_bytes while being read. Throws Error.
    std::string read_all();

  private:
    std::string path_, what_;
    uint64_t max_ = 0, size_ = 0;
    int fd_ = -1;
};

// The whole contents of a regular file of at most max_bytes. Throws Error("<path>: <cause>").
std::string read_file_bounded(const std::string& path, uint64_t max_bytes, const std::string& what);

// Checks that `path` is a readable regular file of at most max_bytes, without reading it (for
// files a library will read itself). Throws Error("<path>: <cause>").
void check_regular_file(const std::string& path, uint64_t max_bytes, const std::string& what);

// "1.5 GiB", "64 MiB", "812 bytes".
std::string format_bytes(uint64_t n);

// Text from a file (a channel name, a line) for a one-line message: control bytes escaped as
// \xNN, cut after max characters with "...".
std::string printable_excerpt(const std::string& s, size_t max);

}  // namespace spectex
