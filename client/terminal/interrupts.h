// SIGINT and SIGTERM during a local command: the engine looks at the flag every step and stops
// with Cancelled, and the command reports what it left.
#pragma once

#include <atomic>

namespace dembuf::cli {

/// Raised by SIGINT and SIGTERM once CatchInterrupts was called.
const std::atomic<bool>& Interrupted();
void CatchInterrupts();
/// 128 + the signal (130 for SIGINT, 143 for SIGTERM), as a shell reports it.
int InterruptedExit();
/// "SIGINT" or "SIGTERM".
const char* InterruptName();

}  // namespace dembuf::cli
