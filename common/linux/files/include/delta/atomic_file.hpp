// Files written so that a crash or a power loss leaves either the old file
// or the new one, never a mix: for host_id's outputs and for the
// controller's program slots and boot record (docs/flashing.md).
#pragma once

#include <sys/types.h>

#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>

namespace delta {

// Writes content to path atomically: into a temporary file in the same
// folder, flushed to disk, renamed over path, and the folder flushed so
// that the rename itself survives a power loss. On any failure the
// temporary file is removed, path is left as it was, and delta::InputError
// is thrown, naming path and the system's reason. The file gets `mode`
// (0600 for a secret key, 0755 for a program).
void write_file_atomically(const std::string& path, std::string_view content, mode_t mode = 0644);

// The same, written piece by piece: an output too large to hold whole in
// memory (an hour-long log) streams into the temporary, which commit()
// flushes and renames over path. Until then path is as it was; a writer
// destroyed without commit() (an error, an exception) removes its
// temporary, and so does SIGINT or SIGTERM (as for write_file_atomically).
class AtomicFileWriter {
 public:
  // Creates the temporary beside path; InputError when it cannot.
  explicit AtomicFileWriter(const std::string& path, mode_t mode = 0644);
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  ~AtomicFileWriter();

  void write(std::string_view piece);  // InputError on failure (the temporary is removed)
  void commit();                       // flush, rename over path, flush the folder
  const std::string& path() const { return path_; }

 private:
  [[noreturn]] void fail(const char* what);
  std::string path_;
  std::string temporary_;
  mode_t mode_;
  int fd_{-1};
  int slot_{-1};
};

// Commits several writers as one: SIGINT and SIGTERM are held back from
// the first rename until the last file is in place, so that an
// interruption leaves all of them whole or (before) none of them.
void commit_together(std::initializer_list<AtomicFileWriter*> writers);

// A command's several outputs, written so (e.g. a result and its plot).
void write_files_atomically(
    std::initializer_list<std::pair<const std::string*, std::string_view>> files);

// Makes SIGINT and SIGTERM remove the temporary files write_file_atomically
// has open before the process ends by the signal as it would have, so that
// Ctrl-C leaves nothing beside the outputs (host_id's main calls it; a
// program with its own handlers for these signals does not).
void remove_temporaries_on_signals();

// The registry behind it, for write_file_atomically and the tests: a path
// to remove if a signal comes (async-signal-safe: fixed slots, no heap).
// Returns the slot, or -1 when all are taken (the file is then not
// removed on a signal, as before).
int register_temporary(const std::string& path);
void release_temporary(int slot);

// Renames `from` over `to` (same folder) and flushes the folder; InputError
// on failure, `to` then as it was.
void rename_durably(const std::string& from, const std::string& to);

// Why write_file_atomically could not write `path`, found before any work
// is done: its folder is missing, is not a folder or is not writable, or
// the path is a folder itself; "" when it can. A command checks its
// outputs with it first, so that a missing folder costs no computation.
std::string output_path_problem(const std::string& path);

// Where a command keeps what it has when it could not finish:
// "run.csv" -> "run.partial.csv"; "run" -> "run.partial".
std::string partial_log_path(const std::string& path);

}  // namespace delta
