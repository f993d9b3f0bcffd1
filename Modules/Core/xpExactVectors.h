/**
 * @file xpExactVectors.h
 * @brief Attributes for code that runs wider vectors where the CPU has them and must give the
 *        scalar code's values to the bit: no product and sum fused into one rounding.
 *
 * GCC contracts a product and a sum into an FMA wherever the target has one (AVX-512 implies it),
 * which changes the last bit of a result; `optimize("fp-contract=off")` keeps them apart. Clang
 * fuses only within one source expression, which explicit intrinsics never are, and has no
 * `optimize` attribute.
 */
#ifndef xpExactVectors_h
#define xpExactVectors_h

/** A function written with AVX-512 intrinsics (F, VL and BW), called only where the CPU has them. */
#if defined(__clang__)
#define XP_EXACT_AVX512 __attribute__((target("avx512f,avx512vl,avx512bw")))
#else
#define XP_EXACT_AVX512 __attribute__((target("avx512f,avx512vl,avx512bw"), optimize("fp-contract=off")))
#endif

/** A function written with AVX2 intrinsics (and FMA's target), called only where the CPU has them. */
#if defined(__clang__)
#define XP_EXACT_AVX2 __attribute__((target("avx2,fma")))
#else
#define XP_EXACT_AVX2 __attribute__((target("avx2,fma"), optimize("fp-contract=off")))
#endif

/**
 * A function of plain C++ built twice, for AVX-512 and for the baseline, and picked at load time:
 * loops the compiler vectorises across outputs run eight doubles wide where the CPU has AVX-512,
 * with the baseline's values. GCC on x86-64 only; elsewhere the one plain build.
 */
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define XP_WIDE_EXACT __attribute__((target_clones("avx512f", "default"), optimize("fp-contract=off")))
#else
#define XP_WIDE_EXACT
#endif

#endif
