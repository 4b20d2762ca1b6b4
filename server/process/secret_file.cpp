#include "process/secret_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "notify/notifier.h"

namespace dembuf::server {

std::string ReadSecretFile(const std::string& setting, const std::string& path,
                           std::size_t max_bytes) {
  auto problem = [&](const std::string& what) {
    return std::runtime_error(setting + ": " + path + ": " + what);
  };
  const int fd = open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw problem(errno == ELOOP ? "a link; name the file itself" : std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { close(fd); }
  } closer{fd};
  struct stat status {};
  if (fstat(fd, &status) != 0) throw problem(std::strerror(errno));
  if (!S_ISREG(status.st_mode)) throw problem("not a regular file");
  if (status.st_uid != geteuid() && status.st_uid != 0)
    throw problem("belongs to uid " + std::to_string(status.st_uid) +
                  ", neither this daemon's account nor root (chown root FILE)");
  // Members of the daemon's group may read it (root:dembuf 0640), no one else; only its owner
  // may write.
  if ((status.st_mode & S_IRGRP) != 0 && status.st_gid != getegid())
    throw problem("group " + std::to_string(status.st_gid) +
                  " may read it, not this daemon's group alone (chgrp dembuf FILE, or chmod "
                  "0600 FILE)");
  if ((status.st_mode & (S_IWGRP | S_IROTH | S_IWOTH | S_IXOTH)) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(status.st_mode & 07777));
    throw problem(std::string("mode ") + mode +
                  " lets other accounts read or change it (chmod 0640 FILE)");
  }
  if (static_cast<std::size_t>(status.st_size) > max_bytes)
    throw problem("longer than " + std::to_string(max_bytes) + " bytes");
  std::string text(max_bytes + 1, '\0');
  std::size_t got = 0;
  for (ssize_t n; got < text.size() && (n = read(fd, text.data() + got, text.size() - got)) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      throw problem(std::strerror(errno));
    }
    got += static_cast<std::size_t>(n);
  }
  if (got > max_bytes) throw problem("longer than " + std::to_string(max_bytes) + " bytes");
  text.resize(got);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' '))
    text.pop_back();
  if (text.empty()) throw problem("empty");
  return text;
}

std::string ReadHookUrl(const std::string& path) {
  const std::string url = ReadSecretFile("notify_url_file", path);
  try {
    ParseHookUrl(url);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error("notify_url_file: " + path + ": " + e.what());
  }
  return url;
}

}  // namespace dembuf::server
