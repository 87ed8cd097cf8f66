/*
 * The frozen-coefficient reduced model (eqs. 2.19-2.24): the internal step and
 * doStep's split of a communication step into internal steps.
 *
 * The step repeats harness/rom/frozen.py (frozen_advance) operation for
 * operation, in the same order, so that the FMU equals the Python reference
 * bit for bit: no fused multiply-add (rom_internal.h), every lane of the
 * 4-wide blocks does the scalar IEEE operation, and the multiversioned clones
 * below compute the same bits.
 */
#include "rom_internal.h"

#define ROM_MAX_STEPS_PER_CALL 1e15            /* h/dt above this is refused */

#if defined(__GNUC__)
#define ROM_INLINE static inline __attribute__((always_inline))
#else
#define ROM_INLINE static inline
#endif

/* The stepping loop is compiled for AVX-512, AVX2 and the baseline and picked
 * at load time (GCC function multiversioning, x86-64 Linux).  Vector lanes
 * compute exactly what the scalar code does (no reassociation, no FMA), so
 * every variant gives the same bits. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(ROM_NO_CLONES) && (__GNUC__ >= 8)
#define ROM_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define ROM_CLONES
#endif

/* ------------------------------------------------------------------------ */
/* the step (harness/rom/frozen.py frozen_advance, same order of operations)  */
/* ------------------------------------------------------------------------ */

/* M(a^rho) = sum_{a<=b} a^rho_a a^rho_b T_ab (eq. 2.23 projected; exact) and
 * the frozen force term F = p f (eq. 2.19), every n_freeze steps.  Each entry
 * is 0.0 + s_0 T_0 + s_1 T_1 + ... in pair order, as in Python; the entries are
 * computed 32 at a time in registers.  f is the input at the step's time, tau
 * the step's time after the communication point [s] (for the port forces'
 * rates, as for f's: F_j + rate_j tau, F_j itself when the rate is 0). */
ROM_INLINE void refresh(RomState *s, double f, double tau) {
    const RomModel *m = s->model;
    const size_t kr = m->k_rho, np = m->n_pairs, nm = m->nm;
    const double *restrict ar = s->ar;
    double *restrict S = s->S;
    size_t k = 0;
    for (size_t a = 0; a < kr; a++) {
        for (size_t b = a; b < kr; b++) S[k++] = ar[a] * ar[b];
    }
    double *restrict Mt = s->Mt;
    for (size_t i = 0; i < nm; i += 32) {
        double acc[32];
        for (int j = 0; j < 32; j++) acc[j] = 0.0;
        const double *restrict T = m->Tt + i * np;
        for (k = 0; k < np; k++, T += 32) {
            const double sk = S[k];
            for (int j = 0; j < 32; j++) acc[j] += sk * T[j];
        }
        for (int j = 0; j < 32; j++) Mt[i + j] = acc[j];
    }
    double *restrict F = s->F;
    const size_t kv = m->kv_pad;
    if (m->p) {
        for (size_t p = 0; p < kv; p++) F[p] = m->p[p] * f;
    } else {
        for (size_t p = 0; p < kv; p++) F[p] = 0.0;
    }
    /* port forces, frozen with f: F += port_B[j] (F_j(tau) / area), ports in order (harness/rom/frozen.py;
     * F_j(tau) = F_j + rate_j tau as harness/fmu/python_cosim.py computes it) */
    for (size_t j = 0; j < m->n_ports; j++) {
        const double rate = s->port_rate[j];
        const double u = (rate == 0.0 ? s->port_force[j] : s->port_force[j] + rate * tau) / s->area;
        const double *restrict row = m->port_B + j * m->k_v;
        for (size_t p = 0; p < m->k_v; p++) F[p] += row[p] * u;
    }
}

/* Blocks of 4 lanes: GCC/Clang vector extensions (one AVX2 register, two SSE2
 * registers), plain arrays elsewhere.  Every lane does the scalar IEEE
 * operation, in the same order. */
#if defined(__GNUC__)
typedef double v4d __attribute__((vector_size(32)));
#define V4_LOAD(ptr) (*(const v4d *)(const void *)(ptr))
#define V4_STORE(ptr, v) (*(v4d *)(void *)(ptr) = (v))
#define V4_ZERO ((v4d){0.0, 0.0, 0.0, 0.0})
#define V4_SPLAT(x) ((v4d){(x), (x), (x), (x)})
#endif

/* da^rho/dt = -M a^v (eq. 2.20 with frozen M): dr[p] = 0.0 - M[p][0] av[0] - ... */
ROM_INLINE void density_rate(const RomModel *m, double *restrict dr, const double *restrict av,
                             const double *restrict Mt) {
    const size_t krp = m->kr_pad, kv = m->k_v;
    for (size_t p = 0; p < krp; p += 4) {
        const double *restrict col = Mt + p;
#if defined(__GNUC__)
        v4d acc = V4_ZERO;
        for (size_t q = 0; q < kv; q++, col += krp) acc -= V4_LOAD(col) * V4_SPLAT(av[q]);
        V4_STORE(dr + p, acc);
#else
        double acc[4] = {0.0, 0.0, 0.0, 0.0};
        for (size_t q = 0; q < kv; q++, col += krp) {
            for (int j = 0; j < 4; j++) acc[j] -= col[j] * av[q];
        }
        for (int j = 0; j < 4; j++) dr[p + j] = acc[j];
#endif
    }
}

/* da^v/dt = b + F - K a^rho - D a^v (eq. 2.19 with frozen F) */
ROM_INLINE void velocity_rate(const RomModel *m, double *restrict dv, const double *restrict av,
                              const double *restrict ar, const double *restrict F) {
    const size_t kvp = m->kv_pad, kv = m->k_v, kr = m->k_rho;
    for (size_t p = 0; p < kvp; p += 4) {
        const double *restrict col = m->Kt + p;
#if defined(__GNUC__)
        v4d acc = V4_LOAD(m->b + p) + V4_LOAD(F + p);
        for (size_t q = 0; q < kr; q++, col += kvp) acc -= V4_LOAD(col) * V4_SPLAT(ar[q]);
        if (m->Dt) {
            col = m->Dt + p;
            for (size_t q = 0; q < kv; q++, col += kvp) acc -= V4_LOAD(col) * V4_SPLAT(av[q]);
        }
        V4_STORE(dv + p, acc);
#else
        double acc[4];
        for (int j = 0; j < 4; j++) acc[j] = m->b[p + j] + F[p + j];
        for (size_t q = 0; q < kr; q++, col += kvp) {
            for (int j = 0; j < 4; j++) acc[j] -= col[j] * ar[q];
        }
        if (m->Dt) {
            col = m->Dt + p;
            for (size_t q = 0; q < kv; q++, col += kvp) {
                for (int j = 0; j < 4; j++) acc[j] -= col[j] * av[q];
            }
        }
        for (int j = 0; j < 4; j++) dv[p + j] = acc[j];
#endif
    }
}

ROM_INLINE void axpy(double *restrict x, double h, const double *restrict y, size_t n) {
    for (size_t i = 0; i < n; i += 4) {
#if defined(__GNUC__)
        V4_STORE(x + i, V4_LOAD(x + i) + V4_SPLAT(h) * V4_LOAD(y + i));
#else
        for (int j = 0; j < 4; j++) x[i + j] += h * y[i + j];
#endif
    }
}

/* finite and |a| <= bound everywhere: one comparison per value (NaN fails it) */
ROM_INLINE int state_ok(const RomState *s) {
    const double bound = s->model->runaway_bound;
    int ok = 1;
    for (size_t i = 0; i < s->model->k_v; i++) ok &= (fabs(s->av[i]) <= bound);
    for (size_t i = 0; i < s->model->k_rho; i++) ok &= (fabs(s->ar[i]) <= bound);
    return ok;
}

static RomStatus state_failure(const RomState *s, double t, char *message, size_t message_size) {
    const int finite = rom_all_finite(s->av, s->model->k_v) && rom_all_finite(s->ar, s->model->k_rho);
    if (!finite) {
        return rom_fail(message, message_size, "the reduced state became non-finite at t = %.9g s (internal step "
                        "%lld)", t, (long long)s->n);
    }
    return rom_fail(message, message_size,
                    "the reduced state ran away (|a| > %.3g) at t = %.9g s (internal step %lld)",
                    s->model->runaway_bound, t, (long long)s->n);
}

/* count internal steps of length h; returns the number done before a failure
 * (count when all are fine).  Euler: both rates from the old state;
 * symplectic: a^rho first, then the velocity rate with the new a^rho.  Step j
 * starts tau0 + j h after the communication point: a refresh there takes the
 * input f + rate (tau0 + j h) (f itself when the rate is 0, the held input),
 * and each port force likewise F_j + rate_j (tau0 + j h). */
ROM_CLONES
static int64_t run_steps_kernel(RomState *s, int64_t count, double h, double tau0) {
    const RomModel *m = s->model;
    const int64_t nf = s->n_freeze;
    int64_t phase = s->n % nf;
    const int symplectic = m->integrator == ROM_INTEGRATOR_SYMPLECTIC;
    double *restrict av = s->av;
    double *restrict ar = s->ar;
    double *restrict dv = s->dv;
    double *restrict dr = s->dr;
    for (int64_t j = 0; j < count; j++) {
        if (phase == 0) {
            const double rate = s->aux[1], tau = tau0 + (double)j * h;
            refresh(s, rate == 0.0 ? s->f : s->f + rate * tau, tau);
        }
        density_rate(m, dr, av, s->Mt);
        if (symplectic) {
            axpy(ar, h, dr, m->kr_pad);
            velocity_rate(m, dv, av, ar, s->F);
        } else {
            velocity_rate(m, dv, av, ar, s->F);
            axpy(ar, h, dr, m->kr_pad);
        }
        axpy(av, h, dv, m->kv_pad);
        s->n++;
        phase = (phase + 1 == nf) ? 0 : phase + 1;
        if (!state_ok(s)) return j + 1;
    }
    return count;
}

static RomStatus run_steps(RomState *s, int64_t count, double h, double t0, double tau0, char *message,
                           size_t message_size) {
    if (count <= 0) return ROM_OK;
    const int64_t done = run_steps_kernel(s, count, h, tau0);
    if (done < count || !state_ok(s)) return state_failure(s, t0 + (double)done * h, message, message_size);
    return ROM_OK;
}

RomStatus rom_frozen_step(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    const double dt = s->dt;
    const double ratio = h / dt;
    if (!(ratio < ROM_MAX_STEPS_PER_CALL) || s->n > INT64_MAX - (int64_t)ratio - 2) {
        return rom_fail(message, message_size, "communicationStepSize = %g s at t = %.9g s is %g internal steps "
                        "(allowed: fewer than %g)", h, t_comm, ratio, ROM_MAX_STEPS_PER_CALL);
    }
    /* whole steps of dt, then one shortened step to reach t_comm + h exactly */
    const double nearest = floor(ratio + 0.5);
    int64_t n_full;
    double rest = 0.0;
    if (nearest < 1.0 || (ratio < 1.0 && !(fabs(ratio - 1.0) <= ROM_STEP_ROUNDING))) {
        n_full = 0;                               /* dt > h: one internal step of length h (rom_step_exceeds) */
        rest = h;
    } else if (fabs(ratio - nearest) <= ROM_STEP_ROUNDING * fmax(1.0, ratio)) {
        n_full = (int64_t)nearest;
    } else {
        n_full = (int64_t)floor(ratio);
        rest = h - (double)n_full * dt;
    }
    RomStatus status = run_steps(s, n_full, dt, t_comm, 0.0, message, message_size);
    if (status == ROM_OK && (n_full == 0 || rest > ROM_SHORT_STEP_MIN * dt)) {
        status = run_steps(s, 1, rest, t_comm + (double)n_full * dt, (double)n_full * dt, message, message_size);
    }
    return status;     /* on failure the instance is unusable; the message names the time */
}

RomStatus rom_frozen_advance(RomState *s, int64_t n_steps, char *message, size_t message_size) {
    const double t0 = s->time;
    const RomStatus status = run_steps(s, n_steps, s->dt, t0, 0.0, message, message_size);
    s->time = t0 + (double)n_steps * s->dt;
    return status;
}

/* rho_j = sum_q Prho[j][q] a^rho_q, from 0.0 in q order */
double rom_frozen_rho_probe(const RomState *s, uint32_t j) {
    const size_t kr = s->model->k_rho;
    const double *row = s->model->Prho + (size_t)j * kr;
    double rho = 0.0;
    for (size_t q = 0; q < kr; q++) rho += row[q] * s->ar[q];
    return rho;
}
