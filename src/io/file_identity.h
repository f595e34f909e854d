#pragma once
// Files by identity, not by spelling: "d/a.exr", "d/../d/a.exr", "d//a.exr", a path through a
// symbolic link to d, and a hard link are one file. Used to refuse any output that is a file the
// same command reads, and two outputs of one batch that are one file.
#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

namespace spectex {

struct FileId {
    dev_t dev = 0;
    ino_t ino = 0;
    bool operator==(const FileId& o) const { return dev == o.dev && ino == o.ino; }
};

// Device and inode of an existing file, after following links; nothing when it does not exist.
std::optional<FileId> file_id(const std::string& path);

// Where a path would be written: the absolute path with every existing folder resolved through
// its links and "." / ".." / "//" folded away (std::filesystem::weakly_canonical), and the
// identity of the file already there, if any.
struct OutputTarget {
    std::string key;
    std::optional<FileId> existing;
    bool same_as(const OutputTarget& o) const {
        return key == o.key || (existing && existing == o.existing);
    }
};
OutputTarget output_target(const std::string& path);

// The files a command reads, each with the option that names it ("input", "--basis", ...).
class ReadFiles {
  public:
    // Remembers an existing regular file (after links); other paths cannot be overwritten by a
    // rename and are ignored here (their readers refuse them).
    void add(const std::string& path, const std::string& role);
    // The tables spectex ships (observers, illuminants, bases: <data_dir>/spectral/*) and its OCIO
    // config: read by name (--observer cie1931-2, --basis mallett2019, ...), never written.
    void add_data_dir(const std::string& data_dir);
    // "" when `output` is none of them, else a message naming both.
    std::string clash(const std::string& output, const std::string& output_role) const;

  private:
    struct Entry {
        FileId id;
        std::string path, role;
    };
    std::vector<Entry> files_;
};

}  // namespace spectex
