#include <cstdlib>
#include <stdexcept>
#include <string>

#include "vector_copies.h"

namespace dembuf::dem::detail {

namespace {

VectorCopy WidestOnThisCpu() {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
  __builtin_cpu_init();
  // x86-64-v4's AVX-512 subsets and x86-64-v3's AVX2 set, as GCC's target names them.
  if (__builtin_cpu_supports("x86-64-v4")) return VectorCopy::kAvx512;
  if (__builtin_cpu_supports("x86-64-v3")) return VectorCopy::kAvx2;
#endif
  return VectorCopy::kPortable;
}

VectorCopy Choose() {
  const VectorCopy widest = WidestOnThisCpu();
  const char* asked = std::getenv("DEMBUF_VECTOR_COPY");
  if (asked == nullptr || *asked == '\0') return widest;
  const std::string name(asked);
  VectorCopy copy;
  if (name == "avx512")
    copy = VectorCopy::kAvx512;
  else if (name == "avx2")
    copy = VectorCopy::kAvx2;
  else if (name == "portable")
    copy = VectorCopy::kPortable;
  else
    throw std::invalid_argument("DEMBUF_VECTOR_COPY = \"" + name.substr(0, 40) +
                                "\": expected avx512, avx2 or portable");
  // Wider than the CPU: the widest it has (the enum runs widest first).
  return static_cast<int>(copy) < static_cast<int>(widest) ? widest : copy;
}

}  // namespace

VectorCopy ChosenVectorCopy() {
  static const VectorCopy chosen = Choose();
  return chosen;
}

}  // namespace dembuf::dem::detail
