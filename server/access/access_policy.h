// Who may do what on this daemon, decided here once for every door into it: the gRPC API,
// the web pages, their JSON API and the result files they serve. The table it implements is
// in docs/service.md ("Access"); tests/server/access_test.sh checks it row by row on both doors.
#pragma once

#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "access/auth.h"
#include "store/store.h"

namespace dembuf::server {

/// How callers are identified. There is one mode for the whole daemon: a daemon that asks
/// for tokens on one address asks for them on every address.
enum class AccessMode {
  kTokens,  ///< every request carries a user's token (the default)
  kLocal,   ///< a request without a token comes from the machine's trusted user, an admin;
            ///< only when the operator says so, and only with every address on loopback
};

/// "tokens" or "local".
const char* AccessModeName(AccessMode mode);

/// What a request does with something a user owns (a job, a sweep, their list).
enum class Action {
  kList,      ///< list the owner's jobs and sweeps
  kRead,      ///< a job's or sweep's state, details and summary
  kWatch,     ///< a live stream of a job's samples
  kFetch,     ///< an ended job's results and files
  kCancel,    ///< cancel a job or sweep
  kDelete,    ///< delete an ended job or sweep and its stored results
  kSubmit,    ///< file new work under the owner's name
  kShareBed,  ///< put a prepared bed in the cache every user's jobs read (no owner: admins)
};

/// A request refused by the policy: `unauthenticated` when it did not say who it is (or said
/// it wrongly), otherwise it is known but may not do this (forbidden).
class AccessDenied : public std::runtime_error {
 public:
  AccessDenied(bool unauthenticated, const std::string& message)
      : std::runtime_error(message), m_unauthenticated(unauthenticated) {}
  bool unauthenticated() const { return m_unauthenticated; }

 private:
  bool m_unauthenticated;
};

/// How soon a token made, revoked or replaced (by `dembufd token-create` or `token-revoke`,
/// another process) is seen: the users are read again this often.
inline constexpr std::chrono::milliseconds kUsersRefresh{250};

class AccessPolicy {
 public:
  /// Reads the users and their token hashes from `store` now, and again every kUsersRefresh
  /// on a thread of its own: a caller is identified from memory, before any other work and
  /// without waiting for the store.
  AccessPolicy(Store& store, AccessMode mode);
  ~AccessPolicy();
  /// Stops reading the users, and waits for the reader: before the store goes (the daemon's
  /// shutdown closes the store while the policy still stands).
  void Stop();
  AccessPolicy(const AccessPolicy&) = delete;
  AccessPolicy& operator=(const AccessPolicy&) = delete;

  AccessMode mode() const { return m_mode; }
  bool tokens_required() const { return m_mode == AccessMode::kTokens; }

  /// The caller of a request, from its "Authorization" value (nothing when the request has
  /// none) or else the token hash of a web session. Throws AccessDenied (unauthenticated).
  Caller Identify(const std::optional<std::string>& authorization,
                  const std::optional<std::string>& session_token_hash = std::nullopt) const;
  /// The holder of `token`, or nothing for a token not known (the web pages' login form).
  std::optional<Caller> HolderOf(const std::string& token) const;
  /// Whether `caller` still is who it was identified as: its token neither revoked nor
  /// replaced, its admin right not taken away. A long-lived stream asks this as it goes and
  /// ends when the answer turns false (within a second of the change). Always true for a
  /// caller without a token (access "local").
  bool StillValid(const Caller& caller) const;

  /// Whether `caller` may do `action` to what `owner` owns: the owner, or an admin.
  static bool Allows(const Caller& caller, Action action, const std::string& owner);

  /// Throws AccessDenied (forbidden) unless Allows; `what` names the thing in the refusal
  /// ("id: job 12", "sweep_id: sweep 3").
  static void Require(const Caller& caller, Action action, const std::string& owner,
                      const std::string& what);

  /// Whose name new work or a listing is under when the request names `requested` ("" for
  /// none): the caller's own, or, for an admin, the one named. Throws AccessDenied when
  /// anyone else names another user.
  static std::string OwnerFor(const Caller& caller, const std::string& requested,
                              const std::string& field = "owner");

  /// The rights of work `caller` files for `owner` (what its jobs may read, such as a stored
  /// result they would reuse): the caller's own when filing for itself, else the owner's, not
  /// the caller's (an admin filing for bob gives bob's job nothing of alice's): an admin's
  /// where every token of that name is an admin's, or in access "local", where whoever reaches
  /// the daemon without a token is one.
  Caller FiledAs(const Caller& caller, const std::string& owner) const;

  /// Whose jobs and sweeps a listing shows, the one rule of every door's lists: an admin's,
  /// everyone's ("") unless naming one; anyone else's, their own (naming another is refused,
  /// as OwnerFor).
  static std::string ListedOwner(const Caller& caller, const std::string& requested);

 private:
  /// The users as the store has them now, by token hash.
  void ReadUsers();
  std::optional<Caller> CallerOfHash(const std::string& token_hash) const;

  Store& m_store;
  AccessMode m_mode;
  mutable std::mutex m_users_mutex;
  std::map<std::string, User> m_users;  ///< by token hash
  std::mutex m_stop_mutex;
  std::condition_variable_any m_stop;
  std::jthread m_reader;  ///< last: stopped and joined before the members above go
};

}  // namespace dembuf::server
