// A secret the daemon reads from a file of its own (the chat hook's URL): kept out of the
// configuration file, which --check-config prints and more people may read.
#pragma once

#include <cstddef>
#include <string>

namespace dembuf::server {

/// The file's text without its trailing newline, after checking that it is a regular file
/// (no link followed), of the daemon's account or root, that no other account may read or
/// write, and of at most `max_bytes`. Throws std::runtime_error naming the setting, the
/// path and what is wrong, with the command that fixes it; never its contents.
std::string ReadSecretFile(const std::string& setting, const std::string& path,
                           std::size_t max_bytes = 4096);

/// The chat hook's URL from the notify_url_file setting's file, checked as ParseHookUrl
/// (notify/notifier.h) checks it; throws std::runtime_error beginning "notify_url_file: PATH: ".
std::string ReadHookUrl(const std::string& path);

}  // namespace dembuf::server
