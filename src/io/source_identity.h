#pragma once
// A bake's source, as its output's header records it (spectex:sourceSize, sourceMtime and
// sourceHash: provenance_key::kSource* in io/provenance_keys.h), so that --update can tell a
// replaced source from an unchanged one whatever the dates say (a restore, `rsync -t` or a
// checkout can put an older-dated file in place).
//
// The hash is FNV-1a 64 (base/fnv1a.h) over the file's bytes, in file order. A bake computes
// it while the image is decoded: the reader reads through a descriptor that hashes what it reads
// (io/image_source.cpp); bytes the decoder skipped or read out of order are hashed at the end, so
// no byte is read twice from the disk in the common case (PNG, JPEG, scanline TIFF and EXR read in
// order). The header is written before the pixels, so the bake writes a placeholder of the same
// length and patches it in the temporary file before the rename.
#include <sys/stat.h>

#include <cstdint>
#include <string>

#include "base/fnv1a.h"

namespace spectex {

struct SourceIdentity {
    uint64_t size = 0;
    int64_t mtime_sec = 0;
    long mtime_nsec = 0;
    static SourceIdentity of(const struct stat& st);
    // Bytes in decimal.
    std::string size_text() const;
    // Seconds since the epoch with nine decimals: "1764643200.123456789".
    std::string mtime_text() const;
};

// The hash placeholder a header carries until the bake patches it: same length as a real value.
std::string source_hash_placeholder();

// Continues `h` over the bytes of descriptor fd from offset `from` to `end`. Throws Error naming
// path on a read error or when the file ends early.
void hash_file_range(int fd, uint64_t from, uint64_t end, Fnv1a64& h, const std::string& path);

// FNV-1a 64 of a whole regular file (checked like every file spectex reads): "fnv1a64:<hex>".
std::string hash_file(const std::string& path);

// In the file open on fd (an output being written, before its rename), replaces the value of the
// string attribute `name` of the first header, which must currently be `placeholder`, by `value`
// of the same length. Throws Error naming path when the attribute is not there.
void patch_string_attribute(int fd, const std::string& name, const std::string& placeholder,
                            const std::string& value, const std::string& path);

}  // namespace spectex
