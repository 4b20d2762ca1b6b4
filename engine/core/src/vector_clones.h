// Hot loops compiled once per x86 instruction set: the library is built for x86-64-v2 (every
// x86 machine of the last decade), and a function marked DEMBUF_VECTOR_CLONES gets AVX2 and
// AVX-512 copies as well; the dynamic loader picks the widest the CPU supports. The copies
// give the same bits: the loops are kept free of fused multiply-adds (-ffp-contract=off).
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DEMBUF_VECTOR_CLONES \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define DEMBUF_VECTOR_CLONES
#endif
