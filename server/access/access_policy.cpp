#include "access/access_policy.h"

#include "store/store.h"

namespace dembuf::server {

namespace {

constexpr const char* kNeedsToken =
    "this server needs a token: give --token or set DEMBUF_TOKEN, log in on the web pages, or "
    "send \"Authorization: Bearer TOKEN\" (the lab's admin makes one as the daemon's account: "
    "sudo -u dembuf dembufd --config /etc/dembuf/dembufd.toml token-create NAME)";

}  // namespace

const char* AccessModeName(AccessMode mode) {
  return mode == AccessMode::kTokens ? "tokens" : "local";
}

AccessPolicy::AccessPolicy(Store& store, AccessMode mode) : m_store(store), m_mode(mode) {
  ReadUsers();
  m_reader = std::jthread([this](std::stop_token stop) {
    std::unique_lock lock(m_stop_mutex);
    for (;;) {
      m_stop.wait_for(lock, stop, kUsersRefresh, [&] { return stop.stop_requested(); });
      if (stop.stop_requested()) return;
      lock.unlock();
      try {
        ReadUsers();
      } catch (const std::exception&) {
        // the store is busy or failing: the users known stay, and the next look tries again
      }
      lock.lock();
    }
  });
}

AccessPolicy::~AccessPolicy() {
  Stop();
}

void AccessPolicy::Stop() {
  m_reader.request_stop();
  if (m_reader.joinable()) m_reader.join();
}

void AccessPolicy::ReadUsers() {
  std::map<std::string, User> users;
  for (User& user : m_store.ListUsers()) users.emplace(user.token_hash, std::move(user));
  std::lock_guard lock(m_users_mutex);
  m_users.swap(users);
}

std::optional<Caller> AccessPolicy::CallerOfHash(const std::string& token_hash) const {
  std::lock_guard lock(m_users_mutex);
  const auto found = m_users.find(token_hash);
  if (found == m_users.end()) return std::nullopt;
  return Caller{found->second.name, found->second.admin, true, token_hash};
}

std::optional<Caller> AccessPolicy::HolderOf(const std::string& token) const {
  return CallerOfHash(HashToken(token));
}

Caller AccessPolicy::Identify(const std::optional<std::string>& authorization,
                              const std::optional<std::string>& session_token_hash) const {
  if (authorization) {
    const std::string prefix = "Bearer ";
    if (authorization->rfind(prefix, 0) != 0)
      throw AccessDenied(true, "authorization: expected \"Bearer TOKEN\"");
    const std::optional<Caller> holder = HolderOf(authorization->substr(prefix.size()));
    if (!holder) throw AccessDenied(true, "token: not known to this server");
    return *holder;
  }
  if (session_token_hash)
    if (const std::optional<Caller> holder = CallerOfHash(*session_token_hash)) return *holder;
  if (m_mode == AccessMode::kTokens) throw AccessDenied(true, kNeedsToken);
  return Caller{"local", true, false, ""};
}

bool AccessPolicy::StillValid(const Caller& caller) const {
  if (!caller.token) return true;
  const std::optional<Caller> now = CallerOfHash(caller.token_hash);
  return now && now->name == caller.name && now->admin == caller.admin;
}

bool AccessPolicy::Allows(const Caller& caller, Action action, const std::string& owner) {
  // A shared bed is used by everyone's jobs whose scene names it, and the daemon cannot tell
  // it from one it would prepare without preparing it: only an admin may vouch for it.
  if (action == Action::kShareBed) return caller.admin;
  // Everything else: what a user owns is theirs and the admins'.
  return caller.admin || caller.name == owner;
}

void AccessPolicy::Require(const Caller& caller, Action action, const std::string& owner,
                           const std::string& what) {
  if (Allows(caller, action, owner)) return;
  if (owner.empty()) throw AccessDenied(false, "only an admin may " + what);
  throw AccessDenied(false, what + " belongs to " + owner);
}

Caller AccessPolicy::FiledAs(const Caller& caller, const std::string& owner) const {
  if (owner == caller.name) return caller;
  if (m_mode == AccessMode::kLocal) return Caller{owner, true, false, ""};
  std::lock_guard lock(m_users_mutex);
  bool any = false, all_admin = true;
  for (const auto& [hash, user] : m_users)
    if (user.name == owner) {
      any = true;
      all_admin = all_admin && user.admin;
    }
  return Caller{owner, any && all_admin, false, ""};
}

std::string AccessPolicy::ListedOwner(const Caller& caller, const std::string& requested) {
  if (caller.admin) return requested;
  const std::string owner = OwnerFor(caller, requested);
  Require(caller, Action::kList, owner, "owner: the list of " + owner);
  return owner;
}

std::string AccessPolicy::OwnerFor(const Caller& caller, const std::string& requested,
                                   const std::string& field) {
  if (requested.empty() || requested == caller.name) return caller.name;
  if (!caller.admin)
    throw AccessDenied(false, field + ": " + caller.name + " may act only as " + caller.name +
                                  ", not as " + requested + " (an admin may)");
  return requested;
}

}  // namespace dembuf::server
