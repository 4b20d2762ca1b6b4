#include "owned_files.h"

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

// Why a folder (stat of the folder itself) is not the daemon's to use; "" when it is.
std::string FolderProblem(const struct stat& folder, const std::string& path,
                          const std::string& what) {
  const uid_t me = geteuid();
  const std::string mine = AccountName(me);
  if (!S_ISDIR(folder.st_mode)) return what + " " + path + " is not a folder";
  const std::string found =
      " (owner " + AccountName(folder.st_uid) + ", mode " + ModeText(folder.st_mode) + ")";
  const std::string own_folder = "install -d -m 0700 -o " + mine + " FOLDER";
  // A shared folder such as /tmp: any account may create names in it.
  if ((folder.st_mode & 002) != 0 && (folder.st_mode & S_ISVTX) != 0)
    return what + " " + path + " is shared with other accounts" + found +
           ": one could plant the daemon's files there first. Give dembufd a folder of its own: " +
           own_folder;
  if (folder.st_uid != me) {
    const std::string owner = AccountName(folder.st_uid);
    return what + " " + path + " belongs to another account" + found + ", not to " + mine +
           ", which runs dembufd: " + owner +
           " could plant or read the daemon's files. If it is the daemon's, run dembufd as " +
           owner + " (sudo -u " + owner +
           " dembufd ...); else give dembufd a folder of its own: " + own_folder;
  }
  if ((folder.st_mode & 022) != 0)
    return what + " " + path + " may be written by other accounts" + found +
           ": one could plant or replace the daemon's files. Close it: chmod go-w " + path;
  return "";
}

void CheckFolderFd(int fd, const std::string& path, const std::string& what) {
  struct stat folder {};
  if (fstat(fd, &folder) != 0) throw OwnershipError(SystemError(what + " " + path, errno));
  if (const std::string problem = FolderProblem(folder, path, what); !problem.empty())
    throw OwnershipError(problem);
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
  const std::string shown = path.string();
  if (make && mkdir(shown.c_str(), 0700) != 0 && errno != EEXIST)
    throw OwnershipError(SystemError(what + " " + shown + " cannot be made", errno));
  const int fd = open(shown.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    const int error = errno;
    struct stat link {};
    if (lstat(shown.c_str(), &link) == 0 && S_ISLNK(link.st_mode))
      throw OwnershipError(what + " " + shown +
                           " is a symbolic link: dembufd follows no link to its own files; "
                           "give the folder's real path");
    throw OwnershipError(SystemError(what + " " + shown + " cannot be opened", error));
  }
  OwnedFolder folder(fd, path, what);
  CheckFolderFd(fd, shown, what);
  return folder;
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
  const std::string shown = (m_path / name).string();
  if (!IsPlainName(name)) throw OwnershipError(m_what + ": \"" + name + "\" is not a plain name");
  if (make && mkdirat(m_fd, name.c_str(), 0700) != 0 && errno != EEXIST)
    throw OwnershipError(SystemError(m_what + " " + shown + " cannot be made", errno));
  const int fd = openat(m_fd, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0)
    throw OwnershipError(SystemError(m_what + " " + shown +
                                         " cannot be opened as a folder (a "
                                         "link, or not a folder?)",
                                     errno));
  OwnedFolder folder(fd, m_path / name, m_what);
  CheckFolderFd(fd, shown, m_what);
  return folder;
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

void OwnedFolder::Remove(const std::string& name) const {
  if (IsPlainName(name)) unlinkat(m_fd, name.c_str(), 0);
}

std::string OwnedFolder::ReadFrom(const std::string& name, std::uint64_t offset,
                                  std::uint64_t max_bytes) const {
  if (!Contains(name)) return "";
  // O_NONBLOCK: a fifo planted in place of the file does not hang the daemon (it is refused
  // as not a regular file).
  const int fd = OpenFile(name, O_RDONLY | O_NONBLOCK);
  struct stat file {};
  fstat(fd, &file);
  const auto size = static_cast<std::uint64_t>(file.st_size);
  std::string bytes(size > offset ? std::min(size - offset, max_bytes) : 0, '\0');
  std::size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n =
        pread(fd, bytes.data() + got, bytes.size() - got, static_cast<off_t>(offset + got));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // the file shrank meanwhile
    got += static_cast<std::size_t>(n);
  }
  close(fd);
  bytes.resize(got);
  return bytes;
}

std::string OwnedFolder::ReadTail(const std::string& name, std::uint64_t max_bytes) const {
  if (!Contains(name)) return "";
  const int fd = OpenFile(name, O_RDONLY | O_NONBLOCK);
  struct stat file {};
  fstat(fd, &file);
  close(fd);
  const auto size = static_cast<std::uint64_t>(file.st_size);
  return ReadFrom(name, size > max_bytes ? size - max_bytes : 0, max_bytes);
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
  // Folder `dir` (open) holding the entries under `prefix`, depth first.
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
          struct stat file {};
          fstat(fd, &file);
          const auto size = static_cast<std::uint64_t>(file.st_size);
          if (size > max_bytes - total)
            throw std::runtime_error("the result files pass " + std::to_string(max_bytes) +
                                     " bytes");
          data.resize(size);
          std::size_t got = 0;
          while (got < size) {
            const ssize_t n = pread(fd, data.data() + got, size - got, static_cast<off_t>(got));
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) break;
            got += static_cast<std::size_t>(n);
          }
          data.resize(got);
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
        std::vector<std::string> inside;
        while (const dirent* item = readdir(listing)) {
          const std::string child = item->d_name;
          if (child != "." && child != "..") inside.push_back(child);
          if (inside.size() > max_files) break;  // the count is refused below, with the files
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
