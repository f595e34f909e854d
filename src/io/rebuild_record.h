#pragma once
// The spectex:rebuild* header attributes: what a renderer needs to rebuild a file's spectra from
// the linear RGB they integrate to, so that it can hold three numbers a texel instead of every bin
// (docs/file-format.md, "Rebuilding spectra from RGB", specifies them and gives a reference
// evaluation). Written for the methods whose spectra are a function of their exact colour (the
// basis and the lattice), when the table is small enough to sit in a header.
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "spectral/spectral_method.h"

namespace spectex {

// The most table values a header carries: 2^17 float32 (512 KiB, 683 KiB as base64), four times
// the default lattice on 81 bins (9^3 x 81 = 59,049); larger tables are left out (a renderer then
// holds the bins) rather than making every reader of the header parse megabytes.
constexpr size_t kRebuildTableLimit = size_t(1) << 17;

// How the table is written (spectex:rebuildTableEncoding): the values in the file's sample type,
// half or float, as little-endian bit patterns; in each row (a vertex's or basis spectrum's bins)
// every value after the first replaced by its difference from the one before, modulo 2^16 or 2^32;
// the bytes in planes (every value's byte 0, then every byte 1, ...); a zlib stream (RFC 1950);
// base64. Smooth spectra make small differences and planes of like bytes: the default's table
// takes 33 KB of header instead of the 121 KB of its float32 base64, which on a 512 x 256 texture
// is the difference between 0.59x and 0.65x the basis' bytes. A half file's table in half is
// what a renderer holding it in half evaluates (2^-11 of each value, 2^-25 below 2^-14: within
// the file's rounding).
constexpr const char* kRebuildTableHalf = "half-delta-zlib";
constexpr const char* kRebuildTableFloat = "float-delta-zlib";

// The table's bytes as kRebuildTableHalf (half) or kRebuildTableFloat describes them, before
// base64; row: the values of one row (the file's bins).
std::string encode_rebuild_table(const std::vector<float>& table, size_t row, bool half);

// The attributes, in their order in the header: rule, axis (lattice), weights to RGB, table, its
// encoding, checksum; none when the method has no rule or its table is over the limit. to_rgb:
// 3 x bins, row-major (R, G, B rows), the linear RGB of a unit spectrum at each bin under the
// conditions the method is exact for. wavelength_list: the spectex:wavelengthList the file records
// (the checksum covers it, so a table cannot be moved to a file of other bins unnoticed). half:
// the file's samples are half (the table is written in half), else float.
std::vector<std::pair<std::string, std::string>> rebuild_attributes(
    const RebuildTable& t, const std::vector<double>& to_rgb, const std::string& wavelength_list,
    bool half);

// The checksum the attributes carry: "crc32:<8 hex digits>", CRC-32 (as zlib's crc32) of the rule,
// axis, weights, table, wavelength list and table encoding attributes' texts, each followed by a
// line feed. (A record of an earlier spectex has no encoding, a float32 table, and five texts.)
std::string rebuild_checksum(const std::string& rule, const std::string& axis,
                             const std::string& to_rgb, const std::string& table,
                             const std::string& wavelength_list, const std::string& encoding);

// RFC 4648 base64 (with padding) of n bytes.
std::string base64_encode(const void* data, size_t n);

}  // namespace spectex
