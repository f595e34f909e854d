#pragma once
// Atomic output: a temporary file in the destination folder, fsync, then rename over the final
// name. Until commit() the final name is untouched; a failure, an exception or any terminating
// signal removes the temporary file (SIGKILL cannot be caught: it leaves the temporary, never a
// partial file under the final name).
#include <string>

namespace spectex {

class AtomicFile {
  public:
    explicit AtomicFile(const std::string& final_path);  // creates the temporary file
    ~AtomicFile();                                       // removes it unless committed
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    int fd() const { return fd_; }
    const std::string& temp_path() const { return temp_; }
    const std::string& final_path() const { return final_; }
    // fsync, mode from the umask, close, rename, fsync the folder.
    void commit();

  private:
    std::string final_, temp_;
    int fd_ = -1;
    int slot_ = -1;
    bool committed_ = false;
};

// Throws Error when `path` cannot be an output: its name is longer than the folder allows, or
// something that is not a regular file is there (a device such as /dev/full, a FIFO, a socket, a
// folder, or a link to one of these): a rename would replace it, and it is never ours to replace.
// AtomicFile checks it too; commands call it before any work, so the mistake costs nothing.
void check_output_path(const std::string& path);

// Creates the folder `dir` and its missing parents, like mkdir -p, each with mode 0777 less the
// umask. Safe when other processes (farm shards) create the same folders at the same time: a
// folder that appears meanwhile is taken as made. Throws Error naming the folder and the cause
// (something that is not a folder in the way, permissions, ...).
void make_folders(const std::string& dir);

// Installs the handlers that remove live temporary files on every signal whose default action
// ends the process (SIGINT, SIGTERM, SIGPIPE, SIGUSR1, SIGALRM, SIGXCPU, crashes, ...) and ignores
// SIGXFSZ, so that a file-size limit gives EFBIG (an error we report) instead of killing us.
void install_signal_cleanup();

}  // namespace spectex

namespace spectex {
// Writes all of text to fd (retrying short writes); throws Error naming path on failure.
void write_all(int fd, const std::string& text, const std::string& path);
// Writes a small text file atomically (temporary file, fsync, rename).
void write_text_atomically(const std::string& path, const std::string& text);
}  // namespace spectex
