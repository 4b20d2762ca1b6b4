// Fault injection for the crash tests. The environment variable DEMBUFD_FAULT names one point
// in the daemon where a fault happens, so that a test can make it happen at an exact place:
// - FaultPoint: the daemon kills itself with SIGKILL (no clean-up, as a power cut or kill -9),
//   such as halfway through writing a result;
// - FaultError: the call throws as a failing database would; "NAME:N" throws at the first N
//   passes only.
// Unset, every point costs one comparison. The points: docs/robustness.md.
#pragma once

namespace dembuf::server {

/// Kills the process at once if DEMBUFD_FAULT names `point`.
void FaultPoint(const char* point);

/// Throws SqliteError if DEMBUFD_FAULT names `point` (at most N times with "point:N").
void FaultError(const char* point);

}  // namespace dembuf::server
