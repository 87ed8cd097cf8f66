/*
 * Full SPH step in C (eqs. 2.10-2.11); see sph.h.  Same order of operations
 * as harness/sph/loops.py, no fused multiply-add (the pragmas below,
 * and -ffp-contract=off in the build).
 */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include "sph.h"

#include <math.h>

RomStatus sph_check(const SphOperator *op, char *message, size_t message_size) {
    if (!op) return rom_fail(message, message_size, "sph: no operator");
    if (op->n < 1 || op->k < 1 || op->n > ((int64_t)1 << 31) || op->k > op->n) {
        return rom_fail(message, message_size, "sph: n = %lld particles, k = %lld neighbours out of range",
                        (long long)op->n, (long long)op->k);
    }
    if (!op->index || !op->weight || !op->rho0 || !op->c) {
        return rom_fail(message, message_size, "sph: missing neighbour lists, rho0 or c");
    }
    if (op->flags & ~(uint32_t)63u) return rom_fail(message, message_size, "sph: unknown flag bits 0x%x", op->flags);
    if ((op->flags & SPH_DAMPING) && !op->d) return rom_fail(message, message_size, "sph: damping without d");
    if ((op->flags & SPH_FORCE) && !op->profile) {
        return rom_fail(message, message_size, "sph: force without a profile");
    }
    const int64_t total = op->n * op->k;
    for (int64_t i = 0; i < total; i++) {
        if (op->index[i] < 0 || op->index[i] >= op->n) {
            return rom_fail(message, message_size, "sph: neighbour index %lld of particle %lld out of range [0, %lld)",
                            (long long)op->index[i], (long long)(i / op->k), (long long)op->n);
        }
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

/* the rates, no checks (loops.rates) */
static void rates(const SphOperator *op, const double *restrict v, const double *restrict rho, double g,
                  double *restrict dv, double *restrict drho, double *restrict p) {
    const int64_t n = op->n, k = op->k;
    const int uc = (op->flags & SPH_UNIFORM_C) != 0, ur = (op->flags & SPH_UNIFORM_RHO0) != 0;
    const double *restrict rho0 = op->rho0, *restrict c = op->c;
    for (int64_t j = 0; j < n; j++) {                    /* p_j = c_j (1 - rho_j(0)/rho_j) */
        const double r0 = ur ? rho0[0] : rho0[j];
        const double cj = uc ? c[0] : c[j];
        p[j] = cj * (1.0 - r0 / rho[j]);
    }
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

RomStatus sph_rates(const SphOperator *op, const double *v, const double *rho, double g, double *dv, double *drho,
                    double *p, char *message, size_t message_size) {
    if (sph_check(op, message, message_size) != ROM_OK) return ROM_FAIL;
    if (!v || !rho || !dv || !drho || !p) return rom_fail(message, message_size, "sph: missing array");
    if (!isfinite(g)) return rom_fail(message, message_size, "sph: force value %g is not finite", g);
    rates(op, v, rho, g, dv, drho, p);
    return ROM_OK;
}

static int finite_positive(int64_t n, const double *v, const double *rho) {
    for (int64_t i = 0; i < n; i++) {
        if (!(isfinite(v[i]) && isfinite(rho[i]) && rho[i] > 0.0)) return 0;
    }
    return 1;
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
        if ((s + 1) % check_every == 0 || s + 1 == n_steps) {
            if (!finite_positive(n, v, rho)) {
                if (done) *done = s + 1;
                return rom_fail(message, message_size, "sph: the state became non-finite or rho <= 0 by step %lld",
                                (long long)(s + 1));
            }
        }
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
