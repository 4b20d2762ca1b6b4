// Files and folders a run of this account made, told from those another account may have put
// in their place. A sweep folder may sit where others can write (/tmp, a group's folder); a
// run folder, a summary or a link planted there must not be taken for one of the sweep's own
// runs, nor a link followed when the sweep writes a run.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace dembuf::report {

/// What makes `path` not this account's own ("" when it is, or is absent): a link, a file
/// where a folder should be (or the reverse), another account's, or writable by every account.
std::string ForeignPathProblem(const std::filesystem::path& path, bool folder);

/// The file `path` whole, if it is a regular file of this account that not every account may
/// write, no link, and at most `max_bytes` long; nullopt otherwise (absent included).
std::optional<std::string> ReadOwnFile(const std::filesystem::path& path, std::size_t max_bytes);

}  // namespace dembuf::report
