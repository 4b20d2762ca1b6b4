// Hot loops compiled once per x86 instruction set. The library is built for x86-64-v2 (every
// x86 machine of the last decade); DEMBUF_VECTOR_COPIES_OF defines a function three times, for
// AVX-512, AVX2 and that baseline, and PickCopy takes the one chosen once, when the first
// simulation is made: the widest the CPU has, or a narrower one named by the environment
// variable DEMBUF_VECTOR_COPY (avx512, avx2 or portable), so that the tests can compare the
// copies' results on one machine. The copies give the same bits: the loops are kept free of
// fused multiply-adds (-ffp-contract=off).
#pragma once

namespace dembuf::dem::detail {

/// The copies of the hot loops, widest first.
enum class VectorCopy { kAvx512, kAvx2, kPortable };

/// The copy this process runs (chosen once; see above). A DEMBUF_VECTOR_COPY naming no copy
/// throws std::invalid_argument naming the value and the choices; one naming a copy wider
/// than the CPU runs gets the widest the CPU has.
VectorCopy ChosenVectorCopy();

/// The one of three copies of a function that ChosenVectorCopy() names.
template <class F>
F* PickCopy(F* avx512, F* avx2, F* portable) {
  switch (ChosenVectorCopy()) {
    case VectorCopy::kAvx512:
      return avx512;
    case VectorCopy::kAvx2:
      return avx2;
    case VectorCopy::kPortable:
      break;
  }
  return portable;
}

}  // namespace dembuf::dem::detail

// Clang (the sanitizer builds) and other CPUs compile the three copies alike.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DEMBUF_TARGET_AVX512 __attribute__((target("arch=x86-64-v4")))
#define DEMBUF_TARGET_AVX2 __attribute__((target("arch=x86-64-v3")))
#else
#define DEMBUF_TARGET_AVX512
#define DEMBUF_TARGET_AVX2
#endif

/// Defines the function templates `name`Avx512<E>, `name`Avx2<E> and `name`Portable<E>, for a
/// set of effects E (parts.h), returning `type`: each evaluates `body` (a call of an
/// always-inlined function) compiled for its instruction set.
#define DEMBUF_VECTOR_COPIES_OF(type, name, params, body) \
  template <class E>                                      \
  DEMBUF_TARGET_AVX512 type name##Avx512 params {         \
    return body;                                          \
  }                                                       \
  template <class E>                                      \
  DEMBUF_TARGET_AVX2 type name##Avx2 params {             \
    return body;                                          \
  }                                                       \
  template <class E>                                      \
  type name##Portable params {                            \
    return body;                                          \
  }

/// The copy of a function template defined by DEMBUF_VECTOR_COPIES_OF, for effects E.
#define DEMBUF_PICK_COPY_OF(name, E) PickCopy(name##Avx512<E>, name##Avx2<E>, name##Portable<E>)
