/*
 * Full SPH step in C (eqs. 2.10-2.11); see sph.h.  Same order of operations
 * as harness/sph/loops.py, no fused multiply-add (the pragmas below,
 * and -ffp-contract=off in the build).
 *
 * Two layouts of the operator, the same sums (sph.h): the neighbour lists,
 * and the fixed-offset stencil (SPH_STENCIL) with the weights by offset,
 * contiguous in i, no index loads, the periodic wrap-around only in the
 * first and last rows.  The stencil is the hand-written reference of the
 * numba loop's speed (python -m sphrom.measure.sph_scaling): on x86-64 Linux
 * with GCC or Clang its step loop is compiled three times (AVX-512, AVX2,
 * baseline) and the loader picks the one the CPU runs (target_clones), as
 * numba compiles for the CPU it runs on.  Vector instructions change no bit:
 * every row is still its own chain of the same IEEE operations, and no FMA.
 */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include "sph.h"

#include <math.h>

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(undefined_behavior_sanitizer)
#define SPH_SANITIZED 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define SPH_SANITIZED 1
#endif

/* the step loop's clones for the CPU (GNU ifunc: x86-64 Linux, GCC or Clang; not in the sanitizer build) */
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__) && !defined(SPH_SANITIZED) && \
    defined(__has_attribute)
#if __has_attribute(target_clones)
#define SPH_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#define SPH_INLINE static inline __attribute__((always_inline))
#endif
#endif
#ifndef SPH_CLONES
#define SPH_CLONES
#define SPH_INLINE static inline
#endif

/* rows of a block of the any-K stencil (its partial sums stay in L1), as loops.STENCIL_BLOCK */
#define SPH_STENCIL_BLOCK 256

RomStatus sph_check(const SphOperator *op, char *message, size_t message_size) {
    if (!op) return rom_fail(message, message_size, "sph: no operator");
    if (op->n < 1 || op->k < 1 || op->n > ((int64_t)1 << 31) || op->k > op->n) {
        return rom_fail(message, message_size, "sph: n = %lld particles, k = %lld neighbours out of range",
                        (long long)op->n, (long long)op->k);
    }
    if (!op->index || !op->weight || !op->rho0 || !op->c) {
        return rom_fail(message, message_size, "sph: missing neighbour lists, rho0 or c");
    }
    if (op->flags & ~(uint32_t)127u) return rom_fail(message, message_size, "sph: unknown flag bits 0x%x", op->flags);
    if ((op->flags & SPH_DAMPING) && !op->d) return rom_fail(message, message_size, "sph: damping without d");
    if ((op->flags & SPH_FORCE) && !op->profile) {
        return rom_fail(message, message_size, "sph: force without a profile");
    }
    const int64_t total = op->n * op->k;
    if (op->flags & SPH_STENCIL) {
        for (int64_t m = 0; m < op->k; m++) {
            if (op->index[m] <= -op->n || op->index[m] >= op->n) {
                return rom_fail(message, message_size, "sph: stencil offset %lld out of range (-%lld, %lld)",
                                (long long)op->index[m], (long long)op->n, (long long)op->n);
            }
        }
    } else {
        for (int64_t i = 0; i < total; i++) {
            if (op->index[i] < 0 || op->index[i] >= op->n) {
                return rom_fail(message, message_size,
                                "sph: neighbour index %lld of particle %lld out of range [0, %lld)",
                                (long long)op->index[i], (long long)(i / op->k), (long long)op->n);
            }
        }
    }
    for (int64_t i = 0; i < total; i++) {
        if (!isfinite(op->weight[i])) return rom_fail(message, message_size, "sph: non-finite weight");
    }
    const int64_t nr = (op->flags & SPH_UNIFORM_RHO0) ? 1 : op->n;
    for (int64_t i = 0; i < nr; i++) {
        if (!(op->rho0[i] > 0) || !isfinite(op->rho0[i])) {
            return rom_fail(message, message_size, "sph: rho0[%lld] = %g (must be finite and > 0)", (long long)i,
                            op->rho0[i]);
        }
    }
    return ROM_OK;
}

/* p_j = c_j (1 - rho_j(0)/rho_j), the inner bracket of eq. 2.11 (loops._pressure) */
SPH_INLINE void pressure(const SphOperator *op, const double *restrict rho, double *restrict p) {
    const int64_t n = op->n;
    const int uc = (op->flags & SPH_UNIFORM_C) != 0, ur = (op->flags & SPH_UNIFORM_RHO0) != 0;
    const double *restrict rho0 = op->rho0, *restrict c = op->c;
    for (int64_t j = 0; j < n; j++) {
        const double r0 = ur ? rho0[0] : rho0[j];
        const double cj = uc ? c[0] : c[j];
        p[j] = cj * (1.0 - r0 / rho[j]);
    }
}

/* the neighbour lists (loops.rates without STENCIL) */
SPH_INLINE void general_rows(const SphOperator *op, const double *restrict v, const double *restrict rho,
                             const double *restrict p, double *restrict dv, double *restrict drho) {
    const int64_t n = op->n, k = op->k;
    const int ur = (op->flags & SPH_UNIFORM_RHO0) != 0;
    const double *restrict rho0 = op->rho0;
    for (int64_t i = 0; i < n; i++) {
        const int64_t *restrict idx = op->index + i * k;
        const double *restrict w = op->weight + i * k;
        double sv = 0.0, sp = 0.0;
        for (int64_t m = 0; m < k; m++) {
            const int64_t j = idx[m];
            sv += w[m] * v[j];
            sp += w[m] * p[j];
        }
        const double r0 = ur ? rho0[0] : rho0[i];
        drho[i] = -(rho[i] * rho[i] / r0) * sv;         /* eq. 2.10 */
        dv[i] = -sp / r0;                                /* eq. 2.11, pressure part */
    }
}

/* rows lo..hi-1 of the fixed-offset stencil, no wrap-around (loops._stencil_rows) */
SPH_INLINE void stencil_rows(const SphOperator *op, int64_t lo, int64_t hi, const double *restrict v,
                             const double *restrict rho, const double *restrict p, double *restrict dv,
                             double *restrict drho) {
    const int64_t n = op->n, k = op->k;
    const int64_t *restrict off = op->index;
    const double *restrict w = op->weight, *restrict rho0 = op->rho0;
    const int ur = (op->flags & SPH_UNIFORM_RHO0) != 0;
    const double r0 = rho0[0];
    if (k == 4) {              /* alpha in (1, 1.5): offsets -2, -1, 1, 2; the sums and the finish in one pass */
        const double *restrict w0 = w, *restrict w1 = w + n, *restrict w2 = w + 2 * n, *restrict w3 = w + 3 * n;
        const double *restrict v0 = v + off[0], *restrict v1 = v + off[1], *restrict v2 = v + off[2],
                     *restrict v3 = v + off[3];
        const double *restrict p0 = p + off[0], *restrict p1 = p + off[1], *restrict p2 = p + off[2],
                     *restrict p3 = p + off[3];
        for (int64_t i = lo; i < hi; i++) {      /* one loop per branch of ur: GCC and Clang unswitch it */
            double sv = 0.0, sp = 0.0;
            sv += w0[i] * v0[i];
            sp += w0[i] * p0[i];
            sv += w1[i] * v1[i];
            sp += w1[i] * p1[i];
            sv += w2[i] * v2[i];
            sp += w2[i] * p2[i];
            sv += w3[i] * v3[i];
            sp += w3[i] * p3[i];
            const double ri = ur ? r0 : rho0[i];
            drho[i] = -(rho[i] * rho[i] / ri) * sv;
            dv[i] = -sp / ri;
        }
        return;
    }
    /* any k: the sums of a block of rows in drho, dv, one offset at a time, then the finish */
    for (int64_t b0 = lo; b0 < hi; b0 += SPH_STENCIL_BLOCK) {
        const int64_t b1 = hi - b0 < SPH_STENCIL_BLOCK ? hi : b0 + SPH_STENCIL_BLOCK;
        for (int64_t i = b0; i < b1; i++) drho[i] = dv[i] = 0.0;
        for (int64_t m = 0; m < k; m++) {
            const double *restrict wm = w + m * n, *restrict vm = v + off[m], *restrict pm = p + off[m];
            for (int64_t i = b0; i < b1; i++) {
                drho[i] += wm[i] * vm[i];
                dv[i] += wm[i] * pm[i];
            }
        }
        for (int64_t i = b0; i < b1; i++) {
            const double ri = ur ? r0 : rho0[i];
            drho[i] = -(rho[i] * rho[i] / ri) * drho[i];
            dv[i] = -dv[i] / ri;
        }
    }
}

/* row i of the fixed-offset stencil with the periodic wrap-around (loops._stencil_wrapped) */
SPH_INLINE void stencil_wrapped(const SphOperator *op, int64_t i, const double *restrict v, const double *restrict rho,
                                const double *restrict p, double *restrict dv, double *restrict drho) {
    const int64_t n = op->n, k = op->k;
    double sv = 0.0, sp = 0.0;
    for (int64_t m = 0; m < k; m++) {
        int64_t j = i + op->index[m];
        if (j < 0) {
            j += n;
        } else if (j >= n) {
            j -= n;
        }
        sv += op->weight[m * n + i] * v[j];
        sp += op->weight[m * n + i] * p[j];
    }
    const double r0 = (op->flags & SPH_UNIFORM_RHO0) ? op->rho0[0] : op->rho0[i];
    drho[i] = -(rho[i] * rho[i] / r0) * sv;
    dv[i] = -sp / r0;
}

/* the rates, no checks (loops.rates) */
SPH_INLINE void rates(const SphOperator *op, const double *restrict v, const double *restrict rho, double g,
                      double *restrict dv, double *restrict drho, double *restrict p) {
    const int64_t n = op->n;
    pressure(op, rho, p);
    if (op->flags & SPH_STENCIL) {
        int64_t lo = 0, hi = n;                          /* rows whose neighbours need no wrap-around */
        for (int64_t m = 0; m < op->k; m++) {
            if (-op->index[m] > lo) lo = -op->index[m];
            if (n - op->index[m] < hi) hi = n - op->index[m];
        }
        if (hi < lo) hi = lo;
        stencil_rows(op, lo, hi, v, rho, p, dv, drho);
        for (int64_t i = 0; i < lo; i++) stencil_wrapped(op, i, v, rho, p, dv, drho);
        for (int64_t i = hi; i < n; i++) stencil_wrapped(op, i, v, rho, p, dv, drho);
    } else {
        general_rows(op, v, rho, p, dv, drho);
    }
    if (op->flags & SPH_DAMPING) {
        if (op->flags & SPH_UNIFORM_D) {
            const double d0 = op->d[0];
            for (int64_t i = 0; i < n; i++) dv[i] -= d0 * v[i];
        } else {
            for (int64_t i = 0; i < n; i++) dv[i] -= op->d[i] * v[i];
        }
    }
    if (op->flags & SPH_FORCE) {
        if (op->flags & SPH_UNIFORM_PROFILE) {
            const double f0 = op->profile[0] * g;
            for (int64_t i = 0; i < n; i++) dv[i] += f0;
        } else {
            for (int64_t i = 0; i < n; i++) dv[i] += op->profile[i] * g;
        }
    }
}

SPH_CLONES static void rates_once(const SphOperator *op, const double *v, const double *rho, double g, double *dv,
                                  double *drho, double *p) {
    rates(op, v, rho, g, dv, drho, p);
}

RomStatus sph_rates(const SphOperator *op, const double *v, const double *rho, double g, double *dv, double *drho,
                    double *p, char *message, size_t message_size) {
    if (sph_check(op, message, message_size) != ROM_OK) return ROM_FAIL;
    if (!v || !rho || !dv || !drho || !p) return rom_fail(message, message_size, "sph: missing array");
    if (!isfinite(g)) return rom_fail(message, message_size, "sph: force value %g is not finite", g);
    rates_once(op, v, rho, g, dv, drho, p);
    return ROM_OK;
}

SPH_INLINE int finite_positive(int64_t n, const double *v, const double *rho) {
    for (int64_t i = 0; i < n; i++) {
        if (!(isfinite(v[i]) && isfinite(rho[i]) && rho[i] > 0.0)) return 0;
    }
    return 1;
}

/* the time loop, no checks of the arguments (loops.advance, methods 0 and 1): 0, or the step after which the
 * state stopped being finite with rho > 0 */
SPH_CLONES static int64_t steps(const SphOperator *op, int method, double *v, double *rho, int64_t n_steps, double dt,
                                const double *g, double *work, int64_t check_every) {
    const int64_t n = op->n;
    double *dv = work, *drho = work + n, *p = work + 2 * n;
    for (int64_t s = 0; s < n_steps; s++) {
        const double gs = g ? g[s] : 0.0;
        rates(op, v, rho, gs, dv, drho, p);
        if (method == SPH_METHOD_EULER) {
            for (int64_t i = 0; i < n; i++) {
                v[i] += dt * dv[i];
                rho[i] += dt * drho[i];
            }
        } else {
            for (int64_t i = 0; i < n; i++) rho[i] += dt * drho[i];
            rates(op, v, rho, gs, dv, drho, p);
            for (int64_t i = 0; i < n; i++) v[i] += dt * dv[i];
        }
        if (((s + 1) % check_every == 0 || s + 1 == n_steps) && !finite_positive(n, v, rho)) return s + 1;
    }
    return 0;
}

RomStatus sph_advance(const SphOperator *op, int method, double *v, double *rho, int64_t n_steps, double dt,
                      const double *g, double *work, int64_t check_every, int64_t *done, char *message,
                      size_t message_size) {
    if (done) *done = 0;
    if (sph_check(op, message, message_size) != ROM_OK) return ROM_FAIL;
    if (!v || !rho || !work) return rom_fail(message, message_size, "sph: missing state or work array");
    if (method != SPH_METHOD_EULER && method != SPH_METHOD_SYMPLECTIC) {
        return rom_fail(message, message_size, "sph: method %d (allowed: 0 euler, 1 symplectic)", method);
    }
    if (n_steps < 0 || !(isfinite(dt) && dt > 0) || check_every < 1) {
        return rom_fail(message, message_size, "sph: n_steps = %lld, dt = %g, check_every = %lld out of range",
                        (long long)n_steps, dt, (long long)check_every);
    }
    const int64_t bad = steps(op, method, v, rho, n_steps, dt, g, work, check_every);
    if (bad > 0) {
        if (done) *done = bad;
        return rom_fail(message, message_size, "sph: the state became non-finite or rho <= 0 by step %lld",
                        (long long)bad);
    }
    if (done) *done = n_steps;
    return ROM_OK;
}

RomStatus sph_advance_flat(int64_t n, int64_t k, const int64_t *index, const double *weight, const double *rho0,
                           const double *c, const double *d, const double *profile, uint32_t flags, int method,
                           double *v, double *rho, int64_t n_steps, double dt, const double *g, double *work,
                           int64_t check_every, int64_t *done, char *message, size_t message_size) {
    const SphOperator op = {n, k, index, weight, rho0, c, d, profile, flags};
    return sph_advance(&op, method, v, rho, n_steps, dt, g, work, check_every, done, message, message_size);
}
