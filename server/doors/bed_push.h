// PushBed's receiving end: a bed sent in pieces, gathered on gRPC's callback API so that a
// slow sender holds no thread. What it may cost is bounded before it is read: the first piece
// states the size, which must be within the daemon's limit, and no more bytes than stated are
// taken; a sender that sends nothing for the stream timeout, or less than kMinPushBytesPerSecond
// once that long has passed, is cut off (one byte now and then held a place for good). The
// place under the push caps is held until the bed has been checked (the bytes are in memory
// until then: given back at the last piece, a user's pushes piled up in the queue of calls,
// 1.4 GB here), and given back before the call is answered: the sender's next push is never
// refused for this one.
#pragma once

#include <grpcpp/grpcpp.h>
#include <grpcpp/support/server_callback.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>

#include "dembuf/v1/dembuf.pb.h"
#include "doors/stream_clock.h"
#include "doors/stream_limits.h"

namespace dembuf::server {

/// The largest piece of a bed: a piece and its first piece's scene fit gRPC's default
/// message limit (max_request_kb = 1024) with room to spare.
inline constexpr std::int64_t kBedPieceBytes = 256 << 10;
/// The slowest a push may come, on average, once the stream timeout has passed: a 64 MB bed in
/// 17 minutes (a link of half a megabit).
inline constexpr std::int64_t kMinPushBytesPerSecond = 64 << 10;

class BedPushReactor final : public grpc::ServerReadReactor<v1::BedPiece> {
 public:
  /// Checks and keeps the whole bed: the first piece (its kind, name, size and scene) and
  /// all the bytes; then calls `answer` (on any thread) with the status that ends the call.
  using Answer = std::function<void(grpc::Status)>;
  using Receiver = std::function<void(const v1::BedPiece& first, std::string data, Answer answer)>;

  /// Reads the pieces, at most `max_bytes` in all, then hands them to `receive`; `place`
  /// is its place under the push caps, given back with the answer (just before it).
  static BedPushReactor* Start(grpc::CallbackServerContext* context, StreamClock& clock,
                               std::chrono::seconds idle_timeout, std::int64_t max_bytes,
                               std::optional<StreamLimits::Place> place, Receiver receive) {
    auto* reactor = new BedPushReactor(context, clock, idle_timeout, max_bytes, std::move(place),
                                       std::move(receive));
    reactor->m_started = reactor->m_last_piece = StreamClock::Clock::now();
    reactor->ArmIdleCheck();
    reactor->StartRead(&reactor->m_piece);
    return reactor;
  }

  /// A call refused before anything is read.
  static BedPushReactor* Refuse(grpc::Status status) {
    auto* reactor = new BedPushReactor(std::move(status));
    reactor->Finish(*reactor->m_refusal);
    return reactor;
  }

  void OnReadDone(bool ok) override {
    grpc::Status status;
    {
      std::lock_guard lock(m_mutex);
      if (m_finishing) return;  // the clock cut the push off
      m_last_piece = StreamClock::Clock::now();
      if (ok) {
        status = Take();
        if (status.ok()) {
          StartRead(&m_piece);
          return;
        }
      } else if (m_cancelled) {
        status = grpc::Status(grpc::StatusCode::CANCELLED, "the sender left");
      } else if (!m_first) {
        status = grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "kind: no piece was sent");
      } else if (static_cast<std::int64_t>(m_data.size()) != m_first->size()) {
        status = grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                              "size: " + std::to_string(m_first->size()) + " bytes were stated, " +
                                  std::to_string(m_data.size()) + " sent");
      }
      m_reading_done = true;
      if (!status.ok()) {
        m_finishing = true;
        m_place.reset();
      }
    }
    if (!status.ok()) return Finish(status);
    Hold();  // until the answer, which may come from another thread
    m_receive(*m_first, std::move(m_data), [this](grpc::Status answer) {
      {
        // The bed is checked and its bytes gone: the sender may push again at once.
        std::lock_guard lock(m_mutex);
        m_place.reset();
      }
      Finish(std::move(answer));
      Release();
    });
  }

  void OnCancel() override {
    std::lock_guard lock(m_mutex);
    m_cancelled = true;
  }

  void OnDone() override {
    {
      std::lock_guard lock(m_mutex);
      m_done = true;
    }
    m_place.reset();
    Release();
  }

 private:
  BedPushReactor(grpc::CallbackServerContext* context, StreamClock& clock,
                 std::chrono::seconds idle_timeout, std::int64_t max_bytes,
                 std::optional<StreamLimits::Place> place, Receiver receive)
      : m_context(context),
        m_clock(&clock),
        m_idle_timeout(idle_timeout),
        m_max_bytes(max_bytes),
        m_place(std::move(place)),
        m_receive(std::move(receive)) {}
  explicit BedPushReactor(grpc::Status refusal) : m_refusal(std::move(refusal)) {}

  // Under the lock: takes the piece just read; a status that is not OK ends the call.
  grpc::Status Take() {
    auto invalid = [](const std::string& message) {
      return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, message);
    };
    if (static_cast<std::int64_t>(m_piece.data().size()) > kBedPieceBytes)
      return invalid("data: a piece holds at most " + std::to_string(kBedPieceBytes) + " bytes");
    if (!m_first) {
      if (m_piece.size() < 1 || m_piece.size() > m_max_bytes)
        return grpc::Status(m_piece.size() < 1 ? grpc::StatusCode::INVALID_ARGUMENT
                                               : grpc::StatusCode::RESOURCE_EXHAUSTED,
                            "size: " + std::to_string(m_piece.size()) +
                                " bytes; this server takes 1 to " + std::to_string(m_max_bytes) +
                                " (max_bed_push_mb)");
      m_first = m_piece;
      m_first->clear_data();
      m_data.reserve(std::min<std::size_t>(m_piece.size(), kBedPieceBytes));
    } else if (!m_piece.kind().empty() || !m_piece.name().empty() ||
               !m_piece.scene_toml().empty() || !m_piece.owner().empty() || m_piece.size() != 0) {
      return invalid("kind: only the first piece says what the bed is");
    }
    if (static_cast<std::int64_t>(m_data.size() + m_piece.data().size()) > m_first->size())
      return invalid("size: more bytes were sent than the " + std::to_string(m_first->size()) +
                     " stated");
    m_data += m_piece.data();
    return grpc::Status::OK;
  }

  // Ends the call when no piece came for the idle timeout, or when, that long after its start,
  // less than kMinPushBytesPerSecond came on average since; looks every second until reading
  // ends.
  void ArmIdleCheck() {
    Hold();
    m_clock->At(std::min(m_last_piece + m_idle_timeout,
                         StreamClock::Clock::now() + std::chrono::seconds(1)),
                [this] {
                  std::optional<grpc::Status> cut;
                  {
                    std::lock_guard lock(m_mutex);
                    if (!m_done && !m_reading_done && !m_finishing) {
                      cut = TooSlow();
                      if (cut) {
                        m_finishing = m_reading_done = true;
                        m_place.reset();
                      } else {
                        ArmIdleCheck();
                      }
                    }
                  }
                  if (cut) Finish(*cut);  // the read outstanding then ends, not taken
                  Release();
                });
  }

  // Under the lock: why the push is to be cut off now, if it is.
  std::optional<grpc::Status> TooSlow() const {
    const auto now = StreamClock::Clock::now();
    if (now - m_last_piece >= m_idle_timeout)
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                          "nothing came for " + std::to_string(m_idle_timeout.count()) +
                              " s (stream_write_timeout_s); the push was cut off");
    const double seconds = std::chrono::duration<double>(now - m_started - m_idle_timeout).count();
    if (seconds > 0 && static_cast<double>(m_data.size()) < kMinPushBytesPerSecond * seconds)
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                          "the bed came slower than " +
                              std::to_string(kMinPushBytesPerSecond >> 10) +
                              " KiB/s; the push was cut off");
    return std::nullopt;
  }

  // gRPC holds one reference until OnDone, each clock entry one until it has run.
  void Hold() { m_references.fetch_add(1); }
  void Release() {
    if (m_references.fetch_sub(1) == 1) delete this;
  }

  grpc::CallbackServerContext* m_context = nullptr;
  StreamClock* m_clock = nullptr;
  std::chrono::seconds m_idle_timeout{0};
  std::int64_t m_max_bytes = 0;
  std::optional<StreamLimits::Place> m_place;
  Receiver m_receive;
  std::optional<grpc::Status> m_refusal;

  std::mutex m_mutex;
  v1::BedPiece m_piece;                 ///< the piece being read
  std::optional<v1::BedPiece> m_first;  ///< the first piece, without its data
  std::string m_data;
  StreamClock::Clock::time_point m_started;
  StreamClock::Clock::time_point m_last_piece;
  bool m_cancelled = false;
  bool m_finishing = false;  ///< Finish was called (by the clock, or a refusal while reading)
  bool m_reading_done = false;
  bool m_done = false;
  std::atomic<int> m_references{1};
};

}  // namespace dembuf::server
