#include "dembuf/study/files/own_files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>

namespace dembuf::report {

namespace {

// What makes a file of status `st` not this account's own ("" when it is one).
std::string ForeignStatusProblem(const struct stat& st, bool folder) {
  if (S_ISLNK(st.st_mode)) return "a link";
  if (folder && !S_ISDIR(st.st_mode)) return "not a folder";
  if (!folder && !S_ISREG(st.st_mode)) return "not a regular file";
  if (st.st_uid != geteuid()) return "another account's (uid " + std::to_string(st.st_uid) + ")";
  if (st.st_mode & S_IWOTH) return "writable by every account";
  if (st.st_mode & S_IWGRP) return "writable by its group";
  return "";
}

}  // namespace

bool OwnFolderOpenToOthers(const std::filesystem::path& path) {
  struct stat st {};
  return lstat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode) && st.st_uid == geteuid() &&
         (st.st_mode & (S_IWGRP | S_IWOTH)) != 0;
}

std::string ForeignSweepFolderProblem(const std::filesystem::path& path) {
  struct stat st {};
  if (lstat(path.c_str(), &st) != 0) return errno == ENOENT ? "" : "unreadable";
  if (!S_ISLNK(st.st_mode)) return ForeignStatusProblem(st, true);
  if (st.st_uid != geteuid())
    return "a link of another account's (uid " + std::to_string(st.st_uid) + ")";
  if (stat(path.c_str(), &st) != 0) return "a link to nothing";
  return ForeignStatusProblem(st, true);
}

std::string OpenAncestorProblem(const std::filesystem::path& path) {
  std::error_code error;
  const std::filesystem::path full = std::filesystem::weakly_canonical(path, error);
  if (error) return "";
  for (std::filesystem::path up = full.parent_path();; up = up.parent_path()) {
    struct stat st {};
    if (stat(up.c_str(), &st) == 0) {
      const bool trusted_owner = st.st_uid == geteuid() || st.st_uid == 0;
      const bool others_rename = (st.st_mode & (S_IWGRP | S_IWOTH)) && !(st.st_mode & S_ISVTX);
      if (!trusted_owner)
        return up.string() + " is another account's (uid " + std::to_string(st.st_uid) + ")";
      if (others_rename)
        return up.string() + " is writable by " +
               ((st.st_mode & S_IWOTH) ? "every account" : "its group") +
               " without the sticky bit (chmod +t), so others may move what is in it";
    }
    if (up == up.parent_path()) return "";
  }
}

void CloseToOthersWriting(const std::filesystem::path& path) {
  std::filesystem::permissions(
      path, std::filesystem::perms::group_write | std::filesystem::perms::others_write,
      std::filesystem::perm_options::remove);
}

// (022 while the old mask is read: no moment with a mask more open than either.)
ClosedToOthersWriting::ClosedToOthersWriting() : m_saved(umask(022)) {
  umask(static_cast<mode_t>(m_saved) | 022);
}

ClosedToOthersWriting::~ClosedToOthersWriting() {
  umask(static_cast<mode_t>(m_saved));
}

std::string ForeignPathProblem(const std::filesystem::path& path, bool folder) {
  struct stat st {};
  if (lstat(path.c_str(), &st) != 0) return errno == ENOENT ? "" : "unreadable";
  return ForeignStatusProblem(st, folder);
}

std::optional<std::string> ReadOwnFile(const std::filesystem::path& path, std::size_t max_bytes) {
  // Opened without following a link, then checked through the descriptor: what is read is
  // what was checked.
  const int fd = open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return std::nullopt;
  struct stat st {};
  std::optional<std::string> text;
  if (fstat(fd, &st) == 0 && ForeignStatusProblem(st, false).empty() &&
      static_cast<std::size_t>(st.st_size) <= max_bytes) {
    std::string bytes(static_cast<std::size_t>(st.st_size), '\0');
    std::size_t got = 0;
    while (got < bytes.size()) {
      const ssize_t n = read(fd, bytes.data() + got, bytes.size() - got);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      got += static_cast<std::size_t>(n);
    }
    if (got == bytes.size()) text = std::move(bytes);
  }
  close(fd);
  return text;
}

}  // namespace dembuf::report
