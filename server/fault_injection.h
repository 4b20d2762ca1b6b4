// Fault injection for the crash tests. The environment variable DEMBUFD_FAULT names one point
// in the daemon where it kills itself with SIGKILL (no clean-up, as a power cut or kill -9),
// so that a test can crash it at an exact place, such as halfway through writing a result.
// Unset, every point costs one comparison. The points: docs/robustness.md.
#pragma once

namespace dembuf::server {

/// Kills the process at once if DEMBUFD_FAULT names `point`.
void FaultPoint(const char* point);

}  // namespace dembuf::server
