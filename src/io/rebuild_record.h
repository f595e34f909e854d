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

// The attributes, in their order in the header: rule, axis (lattice), weights to RGB, table,
// checksum; none when the method has no rule or its table is over the limit. to_rgb: 3 x bins,
// row-major (R, G, B rows), the linear RGB of a unit spectrum at each bin under the conditions the
// method is exact for. wavelength_list: the spectex:wavelengthList the file records (the checksum
// covers it, so a table cannot be moved to a file of other bins unnoticed).
std::vector<std::pair<std::string, std::string>> rebuild_attributes(
    const RebuildTable& t, const std::vector<double>& to_rgb, const std::string& wavelength_list);

// The checksum the attributes carry: "crc32:<8 hex digits>", CRC-32 (as zlib's crc32) of the rule,
// axis, weights, table and wavelength list attributes' texts, each followed by a line feed.
std::string rebuild_checksum(const std::string& rule, const std::string& axis,
                             const std::string& to_rgb, const std::string& table,
                             const std::string& wavelength_list);

// RFC 4648 base64 (with padding) of n bytes.
std::string base64_encode(const void* data, size_t n);

}  // namespace spectex
