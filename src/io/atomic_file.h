#pragma once
// Atomic output: a temporary file in the destination folder, fsync, then rename over the final
// name. Until commit() the final name is untouched; a failure, an exception or any terminating
// signal removes the temporary file (SIGKILL cannot be caught: it leaves the temporary, never a
// partial file under the final name).
#include <string>

#include "base/error.h"

namespace spectex {

class AtomicFile {
  public:
    // Creates the temporary file beside where the output lands (output_landing): a link's target.
    explicit AtomicFile(const std::string& final_path);
    ~AtomicFile();  // removes it unless committed
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    int fd() const { return fd_; }
    const std::string& temp_path() const { return temp_; }
    const std::string& final_path() const { return final_; }  // as given, for messages
    // fsync, mode from the umask, close, rename, fsync the folder.
    void commit();

  private:
    std::string final_, landing_, temp_;
    int fd_ = -1;
    int slot_ = -1;
    bool committed_ = false;
};

// The descriptor a path names when it names one of this process's open streams: /dev/stdout (1),
// /dev/stderr (2), /dev/fd/N, /proc/self/fd/N, /proc/thread-self/fd/N or /proc/<our pid>/fd/N,
// spelt directly or reached through symbolic links (followed by their text, as the kernel
// would). -1 for any other path. Such a path is written through, like "-": renaming over it would
// replace the link (as root, the system's /dev/stdout) and the stream would never see the data.
int stream_fd_of(const std::string& path);
// Records which descriptors the process was given (call first thing in main, before anything is
// opened). Only those can be a user's stream: a /proc/self/fd/N that names a descriptor spectex
// opened itself (an output being written, a library's file) is refused by check_output_path, so a
// report can never be written into another output. Without the call every descriptor is taken.
void note_inherited_descriptors();

// "-" when `path` names standard output (stream_fd_of is 1), else `path`: options that take "-"
// for standard output treat /dev/stdout and links to it the same way.
std::string stdout_as_dash(const std::string& path);

// Where an atomic output lands: `path` itself, or, when `path` is a symbolic link (a chain of
// them) to a regular file, that file. The link is never replaced: the rename lands on its target,
// so the link keeps pointing where its owner made it point. A dangling link is refused (Error):
// following it would create a file wherever its text points, which the user never named.
std::string output_landing(const std::string& path);

// Throws Error when `path` cannot be an output: its name is longer than the folder allows, or
// something that is not a regular file is there (a device such as /dev/full, a FIFO, a socket, a
// folder, or a link to one of these, or a dangling link): a rename would replace it, and it is
// never ours to replace. A stream (stream_fd_of) is accepted only when `stream_ok` (text outputs,
// which are written through to it) and must then be open for writing. AtomicFile checks it too;
// commands call it before any work, so the mistake costs nothing.
void check_output_path(const std::string& path, bool stream_ok = false);

// Creates the folder `dir` and its missing parents, like mkdir -p, each with mode 0777 less the
// umask. Safe when other processes (farm shards) create the same folders at the same time: a
// folder that appears meanwhile is taken as made. Throws Error naming the folder and the cause
// (something that is not a folder in the way, permissions, ...) and what it was for (`what`: "the
// output folder", "the cache folder").
void make_folders(const std::string& dir, const std::string& what = "the output folder");

// Installs the handlers that remove live temporary files on every signal whose default action
// ends the process (SIGINT, SIGTERM, SIGPIPE, SIGUSR1, SIGALRM, SIGXCPU, crashes, ...) and ignores
// SIGXFSZ, so that a file-size limit gives EFBIG (an error we report) instead of killing us.
void install_signal_cleanup();

// A batch stopping at a termination request. From defer_termination_requests() on, the first
// SIGTERM, SIGINT or SIGHUP (a farm pre-empting a task, Ctrl-C, a terminal or ssh session that
// closed) no longer ends the process at once: it is
// recorded, the batch starts no new file and the files being baked stop at their next strip
// (BakeInterrupted; their temporaries are removed as ever), the report is finished, and
// end_by_signal ends the process by that same signal. A second one, or any other terminating
// signal, ends it at once (temporaries removed).
void defer_termination_requests();
// The signal recorded since defer_termination_requests (SIGTERM, SIGINT or SIGHUP), or 0.
int termination_requested();
// "SIGTERM", "SIGINT", ... (else "signal N").
std::string signal_name(int sig);
// Removes live temporaries, restores the signal's default action and raises it, so that the
// parent (a shell: 128 + sig, 143 for SIGTERM; Slurm) sees the process ended by the signal.
[[noreturn]] void end_by_signal(int sig);
// Thrown from inside a bake when termination_requested(): the file is not finished, not failed.
class BakeInterrupted : public Error {
  public:
    BakeInterrupted(const std::string& input, int sig)
        : Error(input + ": interrupted by " + signal_name(sig)), sig_(sig) {}
    int signal() const { return sig_; }

  private:
    int sig_;
};

}  // namespace spectex

namespace spectex {
// Writes all of text to fd (retrying short writes); throws Error naming path on failure.
void write_all(int fd, const std::string& text, const std::string& path);
// Writes a small text file atomically (temporary file, fsync, rename), or through to the stream
// the path names (stream_fd_of).
void write_text_atomically(const std::string& path, const std::string& text);
}  // namespace spectex

namespace spectex {
// For a folder spectex owns (its cache): writes `text` as <dir>/<name> through a temporary file in
// <dir> (fsync, rename), creating <dir> and its parents first. The rename replaces the entry itself
// (a link there is replaced, never followed), so a reader never sees a partial entry, and processes
// storing the same name at once leave one whole copy. Returns "" when stored, else the cause (for a
// warning: a cache that cannot be written is not a failure).
std::string store_file_in_folder(const std::string& dir, const std::string& name,
                                 const std::string& text);
// The contents of `path` when it is a regular file (not a link, folder, FIFO or device) of at most
// max_bytes that can be read whole; false otherwise: for a cache entry, anything odd is a miss.
bool read_small_regular_file(const std::string& path, size_t max_bytes, std::string* text);
}  // namespace spectex
