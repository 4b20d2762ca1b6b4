// The files and folders the daemon owns: its database's folder, its log's, the lock note, the
// Slurm work_dir and the job folders in it. Another account on the machine must not be able to
// put a file or a link where the daemon reads or writes, so (as PostgreSQL refuses a data
// directory of the wrong owner or mode, and sshd's StrictModes a home folder others can write):
//  - a folder is used only if it belongs to the daemon's account, is no link, and no other
//    account may write it; else the daemon refuses to start, naming the path, its owner and
//    mode, and the command that fixes it;
//  - what is under it is reached from the folder's descriptor by plain names, never through a
//    link (openat with O_NOFOLLOW), and files are created exclusively (O_EXCL);
//  - a file read back (what a cluster node left) must be a regular file of the daemon's
//    account, and is read within a bound.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace dembuf::server {

/// A file or folder the daemon will not take as its own; the message says why and what fixes it.
class OwnershipError : public std::runtime_error {
 public:
  explicit OwnershipError(const std::string& message, int system_error = 0)
      : std::runtime_error(message), m_system_error(system_error) {}
  /// The errno of a call the system refused (0 for a refusal of the daemon's own).
  int system_error() const { return m_system_error; }

 private:
  int m_system_error;
};

/// An open folder of the daemon's account that no other account may write.
class OwnedFolder {
 public:
  /// Opens `path`, making it (0700) when it is absent and `make` is set; `what` names it in
  /// messages ("the database folder", "slurm.work_dir"). Throws OwnershipError.
  static OwnedFolder Open(const std::filesystem::path& path, const std::string& what, bool make);

  OwnedFolder(OwnedFolder&& other) noexcept;
  OwnedFolder& operator=(OwnedFolder&& other) noexcept;
  OwnedFolder(const OwnedFolder&) = delete;
  OwnedFolder& operator=(const OwnedFolder&) = delete;
  ~OwnedFolder();

  const std::filesystem::path& path() const { return m_path; }
  int fd() const { return m_fd; }

  /// The folder `name` (a plain name) in this one, made (0700) when absent and `make` is set;
  /// checked as Open checks. Throws OwnershipError.
  OwnedFolder Folder(const std::string& name, bool make) const;
  /// Whether `name` is there (a link is there, not followed).
  bool Contains(const std::string& name) const;

  /// Writes the file `name` whole: a new file made exclusively beside it, then renamed over
  /// it (a link of that name is replaced, never followed). Throws std::runtime_error.
  void Write(const std::string& name, std::string_view bytes) const;
  /// Opens the file `name` to append to (made 0600 when absent). Throws OwnershipError when it
  /// is a link or not the daemon's regular file. The caller closes the descriptor.
  int OpenToAppend(const std::string& name) const;
  /// Opens the file `name` to read and write (made 0600 when absent), checked as OpenToAppend.
  int OpenToUpdate(const std::string& name) const;
  /// Opens the file `name` to read, checked as OpenToAppend (it must be there). The caller
  /// closes the descriptor.
  int OpenToRead(const std::string& name) const;
  /// Checks, when `name` is there, that it is a regular file of the daemon's account that no
  /// other account may write. Throws OwnershipError.
  void CheckOwned(const std::string& name) const;
  /// Removes `name` when it is there (a file or a link, never what a link names).
  void Remove(const std::string& name) const;

  /// The bytes of the file `name`, nothing when it is absent. Throws std::runtime_error when
  /// it is a link, not a regular file of the daemon's account, or longer than `max_bytes`.
  std::optional<std::string> Read(const std::string& name, std::uint64_t max_bytes) const;
  /// At most `max_bytes` of the file `name` from byte `offset` (fewer at its end; none when it
  /// is absent). Throws as Read.
  std::string ReadFrom(const std::string& name, std::uint64_t offset,
                       std::uint64_t max_bytes) const;
  /// The last `max_bytes` of the file `name` (all of a shorter one; none when it is absent).
  /// Throws as Read.
  std::string ReadTail(const std::string& name, std::uint64_t max_bytes) const;

  /// The regular files under `roots` (files, or folders of files, in this folder) as paths
  /// relative to it ("snapshots/peak/beads.vtp") with their bytes, sorted by path. A path must
  /// pass `allowed`; a link, a path not allowed, more than `max_files` files or more than
  /// `max_bytes` in all throw std::runtime_error naming it.
  std::vector<std::pair<std::string, std::string>> ReadTree(const std::vector<std::string>& roots,
                                                            bool (*allowed)(std::string_view path),
                                                            std::uint64_t max_bytes,
                                                            std::size_t max_files) const;

 private:
  OwnedFolder(int fd, std::filesystem::path path, std::string what)
      : m_fd(fd), m_path(std::move(path)), m_what(std::move(what)) {}
  int OpenFile(const std::string& name, int flags) const;

  int m_fd = -1;
  std::filesystem::path m_path;
  std::string m_what;
};

/// Checks that an open file is a regular file of the daemon's account that no other account
/// may write; throws OwnershipError naming `path` and `what` otherwise.
void CheckOwnedFile(int fd, const std::string& path, const std::string& what);

/// Whether `name` is one plain name: no separator, not "." or "..", not empty.
bool IsPlainName(std::string_view name);

}  // namespace dembuf::server
