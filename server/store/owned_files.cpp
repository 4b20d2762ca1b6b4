#include "store/owned_files.h"

#include <dirent.h>
#include <fcntl.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>

namespace dembuf::server {

namespace fs = std::filesystem;

namespace {

std::string AccountName(uid_t uid) {
  // getpwuid_r, not getpwuid: the daemon's threads may ask at once.
  struct passwd entry {};
  struct passwd* found = nullptr;
  char buffer[4096];
  if (getpwuid_r(uid, &entry, buffer, sizeof buffer, &found) == 0 && found) return found->pw_name;
  return "uid " + std::to_string(uid);
}

std::string ModeText(mode_t mode) {
  char text[8];
  std::snprintf(text, sizeof text, "%04o", static_cast<unsigned>(mode & 07777));
  return text;
}

std::string SystemError(const std::string& what, int error) {
  return what + ": " + std::strerror(error);
}

// Why a folder (stat of the folder itself) is not the daemon's to use, with what fixes it; ""
// when it may use it.
std::string FolderProblem(const struct stat& folder, const std::string& path,
                          const std::string& what) {
  const std::string me = AccountName(geteuid());
  if (!S_ISDIR(folder.st_mode)) return what + " " + path + " is not a folder";
  const std::string found =
      " (owner " + AccountName(folder.st_uid) + ", mode " + ModeText(folder.st_mode) + ")";
  const std::string own_folder = "give dembufd a folder of its own (install -d -m 0700 -o " + me +
                                 " DIR) and point " + what + " at it";
  // A shared folder such as /tmp: any account may create names in it.
  if ((folder.st_mode & 002) != 0 && (folder.st_mode & S_ISVTX) != 0)
    return what + " " + path + " is shared with other accounts" + found +
           ": one could plant the daemon's files there first; " + own_folder;
  if (folder.st_uid != geteuid()) {
    const std::string owner = AccountName(folder.st_uid);
    return what + " " + path + " belongs to " + owner + found + ", but this dembufd runs as " + me +
           ", and does not use another account's folder (" + owner +
           " could plant or read its files). If " + owner +
           " is the daemon's account, run dembufd as it (sudo -u " + owner + " dembufd ...); " +
           "else " + own_folder;
  }
  if ((folder.st_mode & 022) != 0)
    return what + " " + path + " may be written by other accounts" + found +
           ": one could plant or replace the daemon's files. Close it: chmod go-w " + path;
  return "";
}

// Opens the folder `name` under `dir_fd` (AT_FDCWD for a path) and checks it.
int OpenFolderAt(int dir_fd, const std::string& name, const std::string& shown,
                 const std::string& what, bool make) {
  if (make && mkdirat(dir_fd, name.c_str(), 0700) != 0 && errno != EEXIST)
    throw OwnershipError(SystemError(what + " " + shown + " cannot be made", errno), errno);
  const int fd = openat(dir_fd, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    const int error = errno;
    struct stat entry {};
    if (fstatat(dir_fd, name.c_str(), &entry, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(entry.st_mode))
      throw OwnershipError(what + " " + shown +
                           " is a symbolic link: dembufd follows no link to its own files; "
                           "give the folder's real path");
    if (error == ENOENT)
      throw OwnershipError(what + " " + shown +
                               " does not exist: make it for the daemon's account "
                               "(install -d -m 0700 -o " +
                               AccountName(geteuid()) + " " + shown + ")",
                           error);
    throw OwnershipError(SystemError(what + " " + shown + " cannot be opened", error), error);
  }
  struct stat folder {};
  std::string problem = fstat(fd, &folder) != 0 ? SystemError(what + " " + shown, errno)
                                                : FolderProblem(folder, shown, what);
  if (!problem.empty()) {
    close(fd);
    throw OwnershipError(problem);
  }
  return fd;
}

// At most `count` bytes of the open file from `offset` (fewer at its end, or if it shrank).
std::string ReadAt(int fd, std::uint64_t offset, std::uint64_t count) {
  std::string bytes(count, '\0');
  std::size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n =
        pread(fd, bytes.data() + got, bytes.size() - got, static_cast<off_t>(offset + got));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  bytes.resize(got);
  return bytes;
}

std::uint64_t SizeOf(int fd) {
  struct stat file {};
  return fstat(fd, &file) == 0 ? static_cast<std::uint64_t>(file.st_size) : 0;
}

// A name of its own beside `name`, for a file written whole and renamed into place.
std::string TemporaryName(const std::string& name) {
  static thread_local std::mt19937_64 random{std::random_device{}()};
  char suffix[24];
  std::snprintf(suffix, sizeof suffix, ".%016llx", static_cast<unsigned long long>(random()));
  return "." + name + suffix;
}

}  // namespace

bool IsPlainName(std::string_view name) {
  return !name.empty() && name != "." && name != ".." && name.find('/') == std::string_view::npos &&
         name.find('\0') == std::string_view::npos;
}

void CheckOwnedFile(int fd, const std::string& path, const std::string& what) {
  struct stat file {};
  if (fstat(fd, &file) != 0) throw OwnershipError(SystemError(what + " " + path, errno));
  if (!S_ISREG(file.st_mode)) throw OwnershipError(what + " " + path + " is not a regular file");
  if (file.st_uid != geteuid())
    throw OwnershipError(what + " " + path + " belongs to another account (owner " +
                         AccountName(file.st_uid) + ", mode " + ModeText(file.st_mode) +
                         "), not to " + AccountName(geteuid()) +
                         ", which runs dembufd: it was not made by dembufd, and is not used");
  if ((file.st_mode & 022) != 0)
    throw OwnershipError(what + " " + path + " may be written by other accounts (mode " +
                         ModeText(file.st_mode) + "): chmod go-w " + path);
}

OwnedFolder OwnedFolder::Open(const fs::path& path, const std::string& what, bool make) {
  return OwnedFolder(OpenFolderAt(AT_FDCWD, path.string(), path.string(), what, make), path, what);
}

OwnedFolder::OwnedFolder(OwnedFolder&& other) noexcept
    : m_fd(std::exchange(other.m_fd, -1)),
      m_path(std::move(other.m_path)),
      m_what(std::move(other.m_what)) {}

OwnedFolder& OwnedFolder::operator=(OwnedFolder&& other) noexcept {
  if (this != &other) {
    if (m_fd >= 0) close(m_fd);
    m_fd = std::exchange(other.m_fd, -1);
    m_path = std::move(other.m_path);
    m_what = std::move(other.m_what);
  }
  return *this;
}

OwnedFolder::~OwnedFolder() {
  if (m_fd >= 0) close(m_fd);
}

OwnedFolder OwnedFolder::Folder(const std::string& name, bool make) const {
  if (!IsPlainName(name)) throw OwnershipError(m_what + ": \"" + name + "\" is not a plain name");
  return OwnedFolder(OpenFolderAt(m_fd, name, (m_path / name).string(), m_what, make),
                     m_path / name, m_what);
}

bool OwnedFolder::Contains(const std::string& name) const {
  struct stat entry {};
  return IsPlainName(name) && fstatat(m_fd, name.c_str(), &entry, AT_SYMLINK_NOFOLLOW) == 0;
}

void OwnedFolder::Write(const std::string& name, std::string_view bytes) const {
  const std::string shown = (m_path / name).string();
  if (!IsPlainName(name))
    throw std::runtime_error(m_what + ": \"" + name + "\" is not a plain name");
  const std::string temporary = TemporaryName(name);
  const int fd =
      openat(m_fd, temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error(SystemError("cannot write " + shown, errno));
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = errno;
      close(fd);
      unlinkat(m_fd, temporary.c_str(), 0);
      throw std::runtime_error(SystemError("cannot write " + shown, error));
    }
    written += static_cast<std::size_t>(n);
  }
  close(fd);
  if (renameat(m_fd, temporary.c_str(), m_fd, name.c_str()) != 0) {
    const int error = errno;
    unlinkat(m_fd, temporary.c_str(), 0);
    throw std::runtime_error(SystemError("cannot write " + shown, error));
  }
}

int OwnedFolder::OpenFile(const std::string& name, int flags) const {
  const std::string shown = (m_path / name).string();
  if (!IsPlainName(name)) throw OwnershipError(m_what + ": \"" + name + "\" is not a plain name");
  const int fd = openat(m_fd, name.c_str(), flags | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) {
    const int error = errno;
    struct stat entry {};
    if (fstatat(m_fd, name.c_str(), &entry, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(entry.st_mode))
      throw OwnershipError(shown + " is a symbolic link: dembufd follows no link to its own files");
    throw OwnershipError(SystemError(shown + " cannot be opened", error), error);
  }
  try {
    CheckOwnedFile(fd, shown, "the file");
  } catch (...) {
    close(fd);
    throw;
  }
  return fd;
}

int OwnedFolder::OpenToAppend(const std::string& name) const {
  return OpenFile(name, O_WRONLY | O_APPEND | O_CREAT);
}

int OwnedFolder::OpenToUpdate(const std::string& name) const {
  return OpenFile(name, O_RDWR | O_CREAT);
}

int OwnedFolder::OpenToRead(const std::string& name) const {
  // O_NONBLOCK: a fifo planted in place of the file does not hang the daemon (it is refused
  // as not a regular file).
  return OpenFile(name, O_RDONLY | O_NONBLOCK);
}

void OwnedFolder::CheckOwned(const std::string& name) const {
  if (Contains(name)) close(OpenToRead(name));
}

void OwnedFolder::Remove(const std::string& name) const {
  if (IsPlainName(name)) unlinkat(m_fd, name.c_str(), 0);
}

std::string OwnedFolder::ReadFrom(const std::string& name, std::uint64_t offset,
                                  std::uint64_t max_bytes) const {
  if (!Contains(name)) return "";
  const int fd = OpenToRead(name);
  const std::uint64_t size = SizeOf(fd);
  std::string bytes = ReadAt(fd, offset, size > offset ? std::min(size - offset, max_bytes) : 0);
  close(fd);
  return bytes;
}

std::string OwnedFolder::ReadTail(const std::string& name, std::uint64_t max_bytes) const {
  if (!Contains(name)) return "";
  const int fd = OpenToRead(name);
  const std::uint64_t size = SizeOf(fd);
  std::string bytes = ReadAt(fd, size > max_bytes ? size - max_bytes : 0, max_bytes);
  close(fd);
  return bytes;
}

std::optional<std::string> OwnedFolder::Read(const std::string& name,
                                             std::uint64_t max_bytes) const {
  if (!Contains(name)) return std::nullopt;
  std::string bytes = ReadFrom(name, 0, max_bytes + 1);
  if (bytes.size() > max_bytes)
    throw std::runtime_error((m_path / name).string() + " holds more than " +
                             std::to_string(max_bytes) + " bytes");
  return bytes;
}

std::vector<std::pair<std::string, std::string>> OwnedFolder::ReadTree(
    const std::vector<std::string>& roots, bool (*allowed)(std::string_view path),
    std::uint64_t max_bytes, std::size_t max_files) const {
  std::vector<std::pair<std::string, std::string>> files;
  std::uint64_t total = 0;
  // The entries `names` of the open folder `dir_fd`, whose paths start with `prefix`, depth
  // first; nothing is followed, and every path must be allowed.
  auto walk = [&](auto&& self, int dir_fd, const std::string& prefix,
                  const std::vector<std::string>& names) -> void {
    for (const std::string& name : names) {
      const std::string path = prefix.empty() ? name : prefix + "/" + name;
      struct stat entry {};
      if (fstatat(dir_fd, name.c_str(), &entry, AT_SYMLINK_NOFOLLOW) != 0) continue;
      if (!allowed(path))
        throw std::runtime_error("a result file or folder with a name not allowed: \"" +
                                 path.substr(0, 80) + "\"");
      if (S_ISREG(entry.st_mode)) {
        if (files.size() == max_files)
          throw std::runtime_error("more than " + std::to_string(max_files) + " result files");
        const int fd = openat(dir_fd, name.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
        if (fd < 0) throw std::runtime_error(SystemError("cannot read " + path, errno));
        std::string data;
        try {
          CheckOwnedFile(fd, path, "the result file");
          const std::uint64_t size = SizeOf(fd);
          if (size > max_bytes - total)
            throw std::runtime_error("the result files pass " + std::to_string(max_bytes) +
                                     " bytes");
          data = ReadAt(fd, 0, size);
        } catch (...) {
          close(fd);
          throw;
        }
        close(fd);
        total += data.size();
        files.emplace_back(path, std::move(data));
      } else if (S_ISDIR(entry.st_mode)) {
        const int sub =
            openat(dir_fd, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        if (sub < 0) throw std::runtime_error(SystemError("cannot read " + path, errno));
        DIR* listing = fdopendir(sub);
        if (!listing) {
          close(sub);
          throw std::runtime_error(SystemError("cannot read " + path, errno));
        }
        // (More names than files may be taken: the count is refused with the files.)
        std::vector<std::string> inside;
        while (const dirent* item = readdir(listing)) {
          const std::string child = item->d_name;
          if (child != "." && child != "..") inside.push_back(child);
          if (inside.size() > max_files) break;
        }
        std::sort(inside.begin(), inside.end());
        try {
          self(self, dirfd(listing), path, inside);
        } catch (...) {
          closedir(listing);
          throw;
        }
        closedir(listing);
      } else {
        throw std::runtime_error(path + " is not a regular file or folder (a link?)");
      }
    }
  };
  walk(walk, m_fd, "", roots);
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace dembuf::server
