// Files and folders a run of this account made, distinguished from those another account may have
// put in their place or changed. A result is trusted only in a file of this account that no other
// account may write, in folders of this account that no other may write: group members are
// other accounts too, and in a folder they may write they can swap a file or plant a link
// between a check and a write. So a sweep writes its folder closed to others' writing
// (ClosedToOthersWriting), and refuses a folder that is not (sshd's StrictModes does the same
// for a home folder).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace dembuf::report {

/// What makes `path` not this account's own ("" when it is, or is absent): a link, a file
/// where a folder should be (or the reverse), another account's, or writable by its group or
/// every account.
std::string ForeignPathProblem(const std::filesystem::path& path, bool folder);

/// Whether `path` is a folder of this account, no link, that its group or every account may
/// write (as an older dembuf left its run folders under umask 002): a sweep closes such a
/// folder of its own, and deletes such a run folder before running its point again.
bool OwnFolderOpenToOthers(const std::filesystem::path& path);

/// What makes the folder `path` not one to keep a sweep in ("" when it is, or is absent), as
/// ForeignPathProblem, but a link of this account's own is followed (to a folder checked alike).
std::string ForeignSweepFolderProblem(const std::filesystem::path& path);

/// What makes a folder above `path` one where another account could move `path` away and put
/// a link in its place ("" when none is): a folder that is neither this account's nor root's,
/// or one its group or every account may write without the sticky bit (/tmp has it).
std::string OpenAncestorProblem(const std::filesystem::path& path);

/// Takes group and others' write permission from `path` (followed if a link): what a folder's
/// default ACL gives a new file or folder, which the umask does not limit. Throws
/// std::filesystem::filesystem_error.
void CloseToOthersWriting(const std::filesystem::path& path);

/// While alive, files and folders this process makes are closed to others' writing (the umask
/// gains 022), whatever the user's umask: with 002, a sweep's own runs would be refused when
/// it resumes. Restores the umask at the end.
class ClosedToOthersWriting {
 public:
  ClosedToOthersWriting();
  ~ClosedToOthersWriting();
  ClosedToOthersWriting(const ClosedToOthersWriting&) = delete;
  ClosedToOthersWriting& operator=(const ClosedToOthersWriting&) = delete;

 private:
  unsigned m_saved;
};

/// The file `path` whole, if it is a regular file of this account that no other account may
/// write, no link, and at most `max_bytes` long; nullopt otherwise (absent included). It is
/// opened without waiting (a FIFO in its place does not hang the reader).
std::optional<std::string> ReadOwnFile(const std::filesystem::path& path, std::size_t max_bytes);

}  // namespace dembuf::report
