// A server stream (gRPC's callback API) that holds no thread while it waits: each message is
// made when the last one has been sent, and a stream with nothing to send yet looks again
// later on the StreamClock. Every write has a deadline: a client that stops reading is cut
// off instead of holding its place (and its buffers) for ever.
#pragma once

#include <grpcpp/grpcpp.h>
#include <grpcpp/support/server_callback.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <optional>

#include "doors/stream_clock.h"
#include "doors/stream_limits.h"

namespace dembuf::server {

/// What a stream does next.
struct StreamStep {
  enum Kind { kWrite, kWait, kFinish } kind = kFinish;
  std::chrono::milliseconds wait{0};  ///< kWait: look again after this long
  grpc::Status status;                ///< kFinish: how the call ends

  static StreamStep Write() { return {kWrite, {}, grpc::Status::OK}; }
  static StreamStep Wait(std::chrono::milliseconds wait) { return {kWait, wait, grpc::Status::OK}; }
  static StreamStep Finish(grpc::Status status) { return {kFinish, {}, std::move(status)}; }
};

template <class Message>
class StreamReactor final : public grpc::ServerWriteReactor<Message> {
 public:
  /// Fills the next message (kWrite), or says to wait or to finish. Never runs twice at once.
  using Producer = std::function<StreamStep(Message*)>;

  /// A stream that runs `produce` until it finishes; `place` is its place under the stream
  /// caps, given back when the call is done.
  static StreamReactor* Start(grpc::CallbackServerContext* context, StreamClock& clock,
                              std::chrono::seconds write_timeout,
                              std::optional<StreamLimits::Place> place, Producer produce) {
    auto* reactor =
        new StreamReactor(context, clock, write_timeout, std::move(place), std::move(produce));
    reactor->Pump();
    return reactor;
  }

  /// A call refused before it streams anything.
  static StreamReactor* Refuse(grpc::CallbackServerContext* context, StreamClock& clock,
                               grpc::Status status) {
    return Start(context, clock, std::chrono::seconds(1), std::nullopt,
                 [status](Message*) { return StreamStep::Finish(status); });
  }

  void OnWriteDone(bool ok) override {
    {
      std::lock_guard lock(m_mutex);
      m_writing = false;
      if (!ok) {
        FinishLater(m_timed_out ? grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                                               "the client read nothing for " +
                                                   std::to_string(m_write_timeout.count()) +
                                                   " s; the stream was closed")
                                : grpc::Status(grpc::StatusCode::CANCELLED, "the client left"));
      }
    }
    if (FinishIfDue()) return;
    Pump();
  }

  void OnCancel() override {
    {
      std::lock_guard lock(m_mutex);
      m_cancelled = true;
      // Waiting for the clock: end now. Writing: OnWriteDone(false) ends it.
      if (!m_writing && !m_producing)
        FinishLater(grpc::Status(grpc::StatusCode::CANCELLED, "cancelled"));
    }
    FinishIfDue();
  }

  void OnDone() override {
    {
      std::lock_guard lock(m_mutex);
      m_done = true;
    }
    m_place.reset();  // the stream's place is free once the call is over
    Release();
  }

 private:
  StreamReactor(grpc::CallbackServerContext* context, StreamClock& clock,
                std::chrono::seconds write_timeout, std::optional<StreamLimits::Place> place,
                Producer produce)
      : m_context(context),
        m_clock(clock),
        m_write_timeout(write_timeout),
        m_place(std::move(place)),
        m_produce(std::move(produce)) {}

  // The next step: called with no write outstanding and no clock entry to come.
  void Pump() {
    {
      std::lock_guard lock(m_mutex);
      if (m_finishing) return;
      if (m_cancelled) FinishLater(grpc::Status(grpc::StatusCode::CANCELLED, "cancelled"));
      if (!m_finish_status) m_producing = true;
    }
    if (FinishIfDue()) return;
    const StreamStep step = m_produce(&m_message);
    bool write = false;
    {
      std::lock_guard lock(m_mutex);
      m_producing = false;
      if (m_cancelled) {
        FinishLater(grpc::Status(grpc::StatusCode::CANCELLED, "cancelled"));
      } else if (step.kind == StreamStep::kFinish) {
        FinishLater(step.status);
      } else if (step.kind == StreamStep::kWait) {
        Hold();
        m_clock.At(StreamClock::Clock::now() + step.wait, [this] {
          Pump();
          Release();
        });
      } else {
        write = true;
        m_writing = true;
        m_write_started = StreamClock::Clock::now();
        if (!m_deadline_armed) ArmDeadline(m_write_started + m_write_timeout);
      }
    }
    if (FinishIfDue()) return;
    if (write) this->StartWrite(&m_message);
  }

  // The write deadline, on the clock: a write outstanding for longer cancels the call.
  void ArmDeadline(StreamClock::Clock::time_point when) {
    m_deadline_armed = true;
    Hold();
    m_clock.At(when, [this] {
      {
        // Under the lock, so that OnDone (which takes it) cannot end the call, and its
        // context, meanwhile; gRPC runs OnCancel later, on a thread of its own.
        std::lock_guard lock(m_mutex);
        m_deadline_armed = false;
        if (m_writing && !m_finishing && !m_done) {
          const auto due = m_write_started + m_write_timeout;
          if (StreamClock::Clock::now() >= due) {
            m_timed_out = true;
            m_context->TryCancel();
          } else {
            ArmDeadline(due);
          }
        }
      }
      Release();
    });
  }

  // Under the lock: the call is to finish with `status` once no write is outstanding.
  void FinishLater(grpc::Status status) {
    if (m_finishing || m_finish_status) return;
    m_finish_status = std::move(status);
  }

  // Outside the lock: finishes when FinishLater asked for it and nothing is outstanding.
  bool FinishIfDue() {
    grpc::Status status;
    {
      std::lock_guard lock(m_mutex);
      if (m_finishing) return true;
      if (!m_finish_status || m_writing || m_producing) return false;
      m_finishing = true;
      status = *m_finish_status;
    }
    this->Finish(status);
    return true;
  }

  // gRPC holds one reference until OnDone, each clock entry one until it has run.
  void Hold() { m_references.fetch_add(1); }
  void Release() {
    if (m_references.fetch_sub(1) == 1) delete this;
  }

  grpc::CallbackServerContext* const m_context;
  StreamClock& m_clock;
  const std::chrono::seconds m_write_timeout;
  std::optional<StreamLimits::Place> m_place;
  const Producer m_produce;
  Message m_message;  ///< the message being written (gRPC reads it until OnWriteDone)

  std::mutex m_mutex;
  bool m_writing = false;    ///< a write is outstanding
  bool m_producing = false;  ///< the producer runs
  bool m_cancelled = false;
  bool m_timed_out = false;
  bool m_deadline_armed = false;
  bool m_finishing = false;  ///< Finish was called
  bool m_done = false;       ///< OnDone ran: the call and its context are gone
  std::optional<grpc::Status> m_finish_status;
  StreamClock::Clock::time_point m_write_started;
  std::atomic<int> m_references{1};
};

}  // namespace dembuf::server
