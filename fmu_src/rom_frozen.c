/*
 * Model kind 1, the frozen-coefficient reduced model (eqs. 2.19-2.24): its
 * body of the resources, its state, the internal step and doStep's split of a
 * communication step into internal steps, its outputs, parameters and
 * serialized block, and its table of operations (rom_frozen_kind, at the end).
 *
 * The step repeats harness/rom/frozen.py (frozen_advance) operation for
 * operation, in the same order, so that the FMU equals the Python reference
 * bit for bit: no fused multiply-add (rom_internal.h), every lane of the
 * 4-wide blocks does the scalar IEEE operation, and the multiversioned clones
 * below compute the same bits.
 */
#include "rom_frozen.h"

#include <stdio.h>
#include <stdlib.h>
#include <time.h>


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

/* M from the tensor in pair order: each entry 0.0 + s_0 T_0 + s_1 T_1 + ..., 32 entries in registers at a time */
ROM_INLINE void refresh_tensor(const RomFrozenModel *fm, const double *restrict S,
                               double *restrict Mt) {
    const size_t np = fm->n_pairs, nm = fm->nm;
    for (size_t i = 0; i < nm; i += 32) {
        double acc[32];
        for (int j = 0; j < 32; j++) acc[j] = 0.0;
        const double *restrict T = fm->Tt + i * np;
        for (size_t k = 0; k < np; k++, T += 32) {
            const double sk = S[k];
            for (int j = 0; j < 32; j++) acc[j] += sk * T[j];
        }
        for (int j = 0; j < 32; j++) Mt[i + j] = acc[j];
    }
}

/* M from the tensor stored by its symmetry: the entry (p, q) is 0.0 + s'_0 W[o_0p + q] + s'_1 W[o_1p + q] + ...
 * in pair order, s'_k = (a^rho_a a^rho_b) w_ab.  As w_ab is 1 or 2, s'_k W = s_k (w_ab W) = s_k T[k][p][q]
 * exactly (one rounding of the same product), so every entry has the tensor path's bits.  The rows of M
 * (k_rho x kv_quad, in the scratch Ms) stay in L1 while W's rows stream, each about three times; W
 * (k_rho^3 k_v / 6 values) is about a third of Tt. */
ROM_INLINE void refresh_symmetric(const RomModel *m, const RomFrozenModel *fm, const double *restrict S,
                                  double *restrict Ms, double *restrict Mt) {
    const size_t np = fm->n_pairs, kr = m->k_rho, kv = m->k_v, krp = m->kr_pad, kvq = fm->kv_quad;
    const double *restrict W = fm->W;
    for (size_t i = 0; i < kr * kvq; i++) Ms[i] = 0.0;
    const uint32_t *restrict off = fm->sym_off;
    for (size_t k = 0; k < np; k++, off += kr) {
        const double sk = S[k];
        for (size_t p = 0; p < kr; p++) {
            double *restrict row = Ms + p * kvq;
            const double *restrict w = W + off[p];
            for (size_t q = 0; q < kvq; q += 4) {
#if defined(__GNUC__)
                V4_STORE(row + q, V4_LOAD(row + q) + V4_SPLAT(sk) * V4_LOAD(w + q));
#else
                for (int j = 0; j < 4; j++) row[q + j] += sk * w[q + j];
#endif
            }
        }
    }
    for (size_t p = 0; p < kr; p++) {
        for (size_t q = 0; q < kv; q++) Mt[q * krp + p] = Ms[p * kvq + q];
    }
}

/* M from the particles (eq. 2.23 projected, harness/rom/frozen.py refresh_direct_path in its order):
 * rho_i = 0.0 + U_i0 a_0 + U_i1 a_1 + ..., w_i = rho_i rho_i / rho0_i, M[p][q] = 0.0 + (w_0 U_0p) GU_0q +
 * (w_1 U_1p) GU_1q + ..., particles in order; O(N k_rho k_v) with U^rho and G U^v in cache, where the tensor
 * (n_pairs k_rho k_v values) would stream from memory.  Four rows p at a time: each lane the scalar sum. */
ROM_INLINE void refresh_particles(const RomModel *m, const RomFrozenModel *fm, const double *restrict ar,
                                  double *restrict Mt) {
    const size_t n = fm->n_particles, kr = m->k_rho, kv = m->k_v, krp = m->kr_pad;
    double up[ROM_MAX_MODES + 4] __attribute__((aligned(32)));
    for (size_t i = 0; i < fm->nm; i++) Mt[i] = 0.0;
    for (size_t p = kr; p < krp; p++) up[p] = 0.0;
    for (size_t i = 0; i < n; i++) {
        const double *restrict u = fm->Ur + i * kr;
        double rho = 0.0;
        for (size_t a = 0; a < kr; a++) rho += u[a] * ar[a];
        const double w = rho * rho * fm->inv_rho0[i];
        for (size_t p = 0; p < kr; p++) up[p] = w * u[p];
        const double *restrict g = fm->GUv + i * kv;
        for (size_t q = 0; q < kv; q++) {
            double *restrict col = Mt + q * krp;
            const double gq = g[q];
            for (size_t p = 0; p < krp; p += 4) {
#if defined(__GNUC__)
                V4_STORE(col + p, V4_LOAD(col + p) + V4_LOAD(up + p) * V4_SPLAT(gq));
#else
                for (int j = 0; j < 4; j++) col[p + j] += up[p + j] * gq;
#endif
            }
        }
    }
}

/* M(a^rho) = sum_{a<=b} a^rho_a a^rho_b T_ab (eq. 2.23 projected; exact) and
 * the frozen force term F = p f (eq. 2.19), every n_freeze steps.  Each entry
 * is 0.0 + s_0 T_0 + s_1 T_1 + ... in pair order, as in Python; the entries are
 * computed 32 at a time in registers (or by refresh_symmetric).  f is the input at the step's time, tau
 * the step's time after the communication point [s] (for the port forces'
 * rates, as for f's: F_j + rate_j tau, F_j itself when the rate is 0).
 * A refresh whose inputs (a^rho, f, the port inputs) equal the last one's bit for bit is skipped: M and F
 * already hold its result (a component at rest). */
ROM_INLINE void refresh(RomState *s, const RomFrozenModel *fm, RomFrozenState *fs, double f, double tau) {
    const RomModel *m = s->model;
    const size_t kr = m->k_rho, np = fm->n_pairs, n_ports = rom_port_inputs(m);   /* none with the port channel */
    const double *restrict ar = s->ar;
    double *restrict last = fs->last_in;
    double u[ROM_MAX_PORTS];
    for (size_t j = 0; j < n_ports; j++) {
        const double rate = s->port_rate[j];
        u[j] = (rate == 0.0 ? s->port_force[j] : s->port_force[j] + rate * tau) / s->area;
    }
    if (fs->refreshed && fm->keep_skip && memcmp(last, ar, kr * sizeof(double)) == 0 && memcmp(last + kr, &f, sizeof(double)) == 0 &&
        (n_ports == 0 || memcmp(last + kr + 1, u, n_ports * sizeof(double)) == 0)) {
        return;
    }
    memcpy(last, ar, kr * sizeof(double));
    memcpy(last + kr, &f, sizeof(double));
    if (n_ports) memcpy(last + kr + 1, u, n_ports * sizeof(double));
    fs->refreshed = 1;
    if (fm->particles) {
        refresh_particles(m, fm, ar, fs->Mt);
    } else {
        double *restrict S = fs->S;
        size_t k = 0;
        for (size_t a = 0; a < kr; a++) {
            for (size_t b = a; b < kr; b++) S[k++] = ar[a] * ar[b];
        }
        if (fm->symmetric) {
            for (k = 0; k < np; k++) S[k] *= fm->pair_scale[k];          /* exact: w_ab is 1 or 2 */
            refresh_symmetric(m, fm, S, fs->Ms, fs->Mt);
        } else {
            refresh_tensor(fm, S, fs->Mt);
        }
    }
    double *restrict F = fs->F;
    const size_t kv = m->kv_pad;
    if (fm->p) {
        for (size_t p = 0; p < kv; p++) F[p] = fm->p[p] * f;
    } else {
        for (size_t p = 0; p < kv; p++) F[p] = 0.0;
    }
    /* port forces, frozen with f: F += port_B[j] u_j, u_j = F_j(tau) / area, ports in order (harness/rom/frozen.py;
     * F_j(tau) = F_j + rate_j tau as harness/fmu/check/python_cosim.py computes it) */
    for (size_t j = 0; j < n_ports; j++) {
        const double *restrict row = m->port_B + j * m->k_v;
        for (size_t p = 0; p < m->k_v; p++) F[p] += row[p] * u[j];
    }
}

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
ROM_INLINE void velocity_rate(const RomModel *m, const RomFrozenModel *fm, double *restrict dv,
                              const double *restrict av, const double *restrict ar, const double *restrict F) {
    const size_t kvp = m->kv_pad, kv = m->k_v, kr = m->k_rho;
    for (size_t p = 0; p < kvp; p += 4) {
        const double *restrict col = fm->Kt + p;
#if defined(__GNUC__)
        v4d acc = V4_LOAD(fm->b + p) + V4_LOAD(F + p);
        for (size_t q = 0; q < kr; q++, col += kvp) acc -= V4_LOAD(col) * V4_SPLAT(ar[q]);
        if (fm->Dt) {
            col = fm->Dt + p;
            for (size_t q = 0; q < kv; q++, col += kvp) acc -= V4_LOAD(col) * V4_SPLAT(av[q]);
        }
        V4_STORE(dv + p, acc);
#else
        double acc[4];
        for (int j = 0; j < 4; j++) acc[j] = fm->b[p + j] + F[p + j];
        for (size_t q = 0; q < kr; q++, col += kvp) {
            for (int j = 0; j < 4; j++) acc[j] -= col[j] * ar[q];
        }
        if (fm->Dt) {
            col = fm->Dt + p;
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
    const RomFrozenModel *fm = (const RomFrozenModel *)m->body;
    RomFrozenState *fs = (RomFrozenState *)s->body;
    const int64_t nf = fs->n_freeze;
    int64_t phase = s->n % nf;
    const int symplectic = fm->integrator == ROM_INTEGRATOR_SYMPLECTIC;
    double *restrict av = s->av;
    double *restrict ar = s->ar;
    double *restrict dv = fs->dv;
    double *restrict dr = fs->dr;
    for (int64_t j = 0; j < count; j++) {
        if (phase == 0) {
            const double rate = s->f_rate, tau = tau0 + (double)j * h;
            refresh(s, fm, fs, rate == 0.0 ? s->f : s->f + rate * tau, tau);
        }
        density_rate(m, dr, av, fs->Mt);
        if (symplectic) {
            axpy(ar, h, dr, m->kr_pad);
            velocity_rate(m, fm, dv, av, ar, fs->F);
        } else {
            velocity_rate(m, fm, dv, av, ar, fs->F);
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

/* dt exceeds the communication step h (beyond ROM_STEP_ROUNDING): frozen_step takes one step of length h */
static int frozen_step_exceeds(const RomState *s, double h) {
    if (!s || !s->body) return 0;
    const double ratio = h / ((const RomFrozenState *)s->body)->dt;
    return ratio < 1.0 && !(fabs(ratio - 1.0) <= ROM_STEP_ROUNDING);
}

static double frozen_step_work(const RomState *s);

static RomStatus frozen_step(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    if (!s || !s->body) return rom_fail(message, message_size, "no state");
    const RomFrozenState *fs = (const RomFrozenState *)s->body;
    const double dt = fs->dt;
    const double ratio = h / dt;
    /* the work of one doStep is bounded (rom.h): at most rom_max_steps_per_call internal steps */
    const double work = frozen_step_work(s) + ROM_STEP_OVERHEAD;          /* rom.c rom_step_work */
    const double cap = rom_steps_per_call(work);
    if (!(ratio <= cap) || s->n > INT64_MAX - (int64_t)ratio - 2) {
        return rom_fail(message, message_size, "communicationStepSize = %g s at t = %.9g s is %.3g internal steps "
                        "of dt = %g s, above the cap of %.0f per doStep (the work bound %g multiply-adds over %.0f per "
                        "step at k_v = %u, k_rho = %u, n_freeze = %d, %u ports; allowed: h <= %g s)", h, t_comm,
                        ratio, dt, cap, ROM_MAX_WORK_PER_CALL, work, s->model->k_v, s->model->k_rho,
                        (int)fs->n_freeze, s->model->n_ports, cap * dt);
    }
    /* whole steps of dt, then one shortened step to reach t_comm + h exactly */
    const double nearest = floor(ratio + 0.5);
    int64_t n_full;
    double rest = 0.0;
    if (nearest < 1.0 || frozen_step_exceeds(s, h)) {
        n_full = 0;                               /* dt > h: one internal step of length h */
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

/* multiply-adds of one internal step: the density and velocity rates, the two updates, the runaway check,
 * and 1/n_freeze of a refresh (the pair products and M from the tensor, or M from the particles; the force
 * term and the ports') */
static double frozen_step_work(const RomState *s) {
    if (!s || !s->model->body || !s->body) return 0.0;
    const int32_t n_freeze = ((const RomFrozenState *)s->body)->n_freeze;
    const RomModel *m = s->model;
    const double kv = m->k_v, kr = m->k_rho, kvp = m->kv_pad, krp = m->kr_pad;
    const double step = krp * kv + kvp * (kr + ((m->flags & ROM_FLAG_DAMPING) ? kv : 0.0)) + kvp + krp + kv + kr;
    const RomFrozenModel *fm = (const RomFrozenModel *)m->body;
    const double matrix = fm->particles ? (double)fm->n_particles * (kr + krp + kv * krp) + fm->nm
                                        : (double)fm->n_pairs * (1.0 + fm->nm);
    const double refresh = matrix + kvp + (double)m->n_ports * kv;
    return step + refresh / (double)(n_freeze > 0 ? n_freeze : 1);
}

static RomStatus frozen_advance(RomState *s, int64_t n_steps, char *message, size_t message_size) {
    if (!s || !s->body) return rom_fail(message, message_size, "no state");
    const double t0 = s->time, dt = ((const RomFrozenState *)s->body)->dt;
    const RomStatus status = run_steps(s, n_steps, dt, t0, 0.0, message, message_size);
    s->time = t0 + (double)n_steps * dt;
    return status;
}


/* ------------------------------------------------------------------------ */
/* outputs                                                                   */
/* ------------------------------------------------------------------------ */

/* v_j = sum_q Pv[j][q] a^v_q, from 0.0 in q order */
static double frozen_v_probe(const RomState *s, uint32_t j) {
    if (!s || !s->model->body) return NAN;
    const size_t kv = s->model->k_v;
    const double *row = ((const RomFrozenModel *)s->model->body)->Pv + (size_t)j * kv;
    double v = 0.0;
    for (size_t q = 0; q < kv; q++) v += row[q] * s->av[q];
    return v;
}

/* rho_j = sum_q Prho[j][q] a^rho_q, from 0.0 in q order */
static double frozen_rho_probe(const RomState *s, uint32_t j) {
    if (!s || !s->model->body) return NAN;
    const size_t kr = s->model->k_rho;
    const double *row = ((const RomFrozenModel *)s->model->body)->Prho + (size_t)j * kr;
    double rho = 0.0;
    for (size_t q = 0; q < kr; q++) rho += row[q] * s->ar[q];
    return rho;
}

/* ------------------------------------------------------------------------ */
/* resources: the header's rules, the body                                   */
/* ------------------------------------------------------------------------ */

/* the kind's own header (rom_layout.h ROM_FROZEN_HEAD_*): integrator, n_pairs, n_freeze_default, reserved, dt */
static RomStatus frozen_read_head(const RomHeader *h, const unsigned char *head, uint64_t *doubles, char *message,
                                  size_t message_size) {
    if (!h || !head || !doubles) return rom_fail(message, message_size, "resources: no header");
    const uint32_t integrator = rom_get_u32(head + ROM_FROZEN_HEAD_INTEGRATOR);
    const uint32_t n_pairs = rom_get_u32(head + ROM_FROZEN_HEAD_N_PAIRS);
    const uint32_t n_freeze = rom_get_u32(head + ROM_FROZEN_HEAD_N_FREEZE_DEFAULT);
    const uint32_t reserved = rom_get_u32(head + ROM_FROZEN_HEAD_RESERVED);
    const double dt = rom_get_f64(head + ROM_FROZEN_HEAD_DT);
    if (integrator != ROM_INTEGRATOR_EULER && integrator != ROM_INTEGRATOR_SYMPLECTIC) {
        return rom_fail(message, message_size, "resources: integrator %u is not one of 0 (euler), 1 (symplectic)",
                        integrator);
    }
    const uint64_t kv = h->k_v, kr = h->k_rho, np = h->n_probes;
    /* 0: no refresh tensor; then the particle refresh's sections must be there (frozen_sections_ready) */
    if (n_pairs != 0 && (uint64_t)n_pairs != kr * (kr + 1) / 2) {
        return rom_fail(message, message_size, "resources: n_pairs = %u, expected k_rho (k_rho + 1)/2 = %u (or 0 "
                        "with the particle refresh's sections)", n_pairs, h->k_rho * (h->k_rho + 1) / 2);
    }
    if (n_freeze < 1 || n_freeze > INT32_MAX || reserved != 0) {
        return rom_fail(message, message_size, "resources: n_freeze_default = %u (must be >= 1) or reserved = %u "
                        "(must be 0)", n_freeze, reserved);
    }
    if (!(isfinite(dt) && dt > 0)) {
        return rom_fail(message, message_size, "resources: dt = %g (must be finite and > 0)", dt);
    }
    if (dt < ROM_DT_MIN) {                                 /* internal steps of dt: the work of a doStep (rom.h) */
        return rom_fail(message, message_size, "resources: dt = %g s is below the smallest internal step %g s "
                        "(ROM_DT_MIN; allowed: dt >= %g s)", dt, ROM_DT_MIN, ROM_DT_MIN);
    }
    /* a_v0, a_rho0, K, b, D, p, T, Pv, Prho, probe_x */
    const int damping = (h->flags & ROM_FLAG_DAMPING) != 0, input = (h->flags & ROM_FLAG_INPUT) != 0;
    *doubles = kv + kr + kv * kr + kv + (damping ? kv * kv : 0) + (input ? kv : 0) + (uint64_t)n_pairs * kr * kv +
               np * kv + np * kr + np;
    return ROM_OK;
}

static uint32_t frozen_min_k_rho(const RomHeader *h) {
    (void)h;
    return 1u;
}

/* Whether the tensor T[k][p][q] at t (the resources' bytes, n_pairs x k_rho x k_v) is symmetric in (a, b, p) bit
 * for bit, T[(a,b)][p] = w_ab W[{a, b, p}] with W's row of the sorted triple (i, j, l) T[(i,j)][l] / w_ij, every
 * value finite (harness/rom/operators.py refresh_tensor builds it so). */
static size_t pair_number(size_t a, size_t b, size_t kr) {
    return a * (2 * kr - a + 1) / 2 + (b - a);          /* pairs a <= b in order: a = 0..kr-1, b = a..kr-1 */
}

static int tensor_symmetric(const unsigned char *t, size_t kr, size_t kv) {
    if (!t || kr == 0 || kv == 0) return 0;
    for (size_t a = 0; a < kr; a++) {
        for (size_t b = a; b < kr; b++) {
            const double w_ab = a == b ? 1.0 : 2.0;
            for (size_t p = 0; p < kr; p++) {
                size_t i = a, j = b, l = p;
                if (l < j) { size_t x = j; j = l; l = x; }
                if (j < i) { size_t x = i; i = j; j = x; }
                const double w_ij = i == j ? 1.0 : 2.0;
                const unsigned char *row = t + 8 * (pair_number(a, b, kr) * kr + p) * kv;
                const unsigned char *ref = t + 8 * (pair_number(i, j, kr) * kr + l) * kv;
                for (size_t q = 0; q < kv; q++) {
                    const double value = rom_get_f64(row + 8 * q), want = w_ab * (rom_get_f64(ref + 8 * q) / w_ij);
                    if (!isfinite(value) || memcmp(&value, &want, sizeof(double)) != 0) return 0;
                }
            }
        }
    }
    return 1;
}

/* W, its offsets and the pair scales from a symmetric tensor at t (tensor_symmetric) */
static RomStatus symmetric_load(RomModel *m, RomFrozenModel *fm, const unsigned char *t, char *message,
                                size_t message_size) {
    if (!m || !fm || !t || !fm->W || !fm->pair_scale) return rom_fail(message, message_size, "resources: no tensor");
    const size_t kr = m->k_rho, kv = m->k_v, np = fm->n_pairs, kvq = fm->kv_quad;
    const size_t n_tri = kr * (kr + 1) * (kr + 2) / 6;
    uint32_t *tri = (uint32_t *)calloc(kr * kr * kr, sizeof(uint32_t));
    fm->sym_off = (uint32_t *)calloc(np * kr, sizeof(uint32_t));
    if (!tri || !fm->sym_off || n_tri * kvq > UINT32_MAX) {
        free(tri);
        return rom_fail(message, message_size, "resources: out of memory (the symmetric refresh, k_rho = %u)",
                        m->k_rho);
    }
    uint32_t n = 0;
    for (size_t i = 0; i < kr; i++) {
        for (size_t j = i; j < kr; j++) {
            for (size_t l = j; l < kr; l++, n++) {
                tri[(i * kr + j) * kr + l] = n;
                const double w_ij = i == j ? 1.0 : 2.0;
                const unsigned char *ref = t + 8 * (pair_number(i, j, kr) * kr + l) * kv;
                for (size_t q = 0; q < kv; q++) fm->W[(size_t)n * kvq + q] = rom_get_f64(ref + 8 * q) / w_ij;
            }
        }
    }
    size_t k = 0;
    for (size_t a = 0; a < kr; a++) {
        for (size_t b = a; b < kr; b++, k++) {
            fm->pair_scale[k] = a == b ? 1.0 : 2.0;
            for (size_t p = 0; p < kr; p++) {
                size_t i = a, j = b, l = p;
                if (l < j) { size_t x = j; j = l; l = x; }
                if (j < i) { size_t x = i; i = j; j = x; }
                fm->sym_off[k * kr + p] = (uint32_t)(tri[(i * kr + j) * kr + l] * kvq);
            }
        }
    }
    free(tri);
    return ROM_OK;
}

/* CPU seconds of `reps` refreshes of M by one path (symmetric or not) at a^rho = a_rho0 */
ROM_CLONES
static double refresh_seconds(const RomModel *m, const RomFrozenModel *fm, int symmetric, double *S, double *Ms,
                              double *Mt, long reps) {
    if (!m || !fm || !S || !Ms || !Mt || (symmetric && !fm->W)) return 0.0;
    const clock_t t0 = clock();
    for (long r = 0; r < reps; r++) {
        if (symmetric) {
            refresh_symmetric(m, fm, S, Ms, Mt);
        } else {
            refresh_tensor(fm, S, Mt);
        }
    }
    return (double)(clock() - t0) / (double)CLOCKS_PER_SEC;
}

/* The refresh path of a symmetric tensor chosen by its measured cost: both paths give the same bits, so the
 * choice moves only the time.  Each path is timed over about 3e5 multiply-adds, twice in turn; the faster
 * (the smaller of its two times) is kept.  Without memory for the scratch the tensor path stays. */
static void choose_refresh(const RomModel *m, RomFrozenModel *fm) {
    if (!m || !fm || !fm->W) return;
    const size_t np = fm->n_pairs, kr = m->k_rho;
    double *S = NULL, *Ms = NULL, *Mt = NULL;           /* aligned as the state's (rom_alloc_arrays) */
    const size_t counts[3] = {np, kr * fm->kv_quad, fm->nm};
    double **ptrs[3] = {&S, &Ms, &Mt};
    void *scratch = rom_alloc_arrays(counts, ptrs, 3);
    fm->symmetric = 0;
    if (scratch) {
        size_t k = 0;
        for (size_t a = 0; a < kr; a++) {
            for (size_t b = a; b < kr; b++) S[k++] = fm->a_rho0[a] * fm->a_rho0[b];
        }
        const double macs = (double)np * (double)fm->nm;
        const long reps = macs >= 3e5 ? 1 : (long)(3e5 / macs);
        double best[2] = {1e300, 1e300};
        for (int round = 0; round < 2; round++) {
            for (int path = 0; path < 2; path++) {
                const double t = refresh_seconds(m, fm, path, S, Ms, Mt, reps);
                if (t < best[path]) best[path] = t;
            }
        }
        fm->symmetric = best[1] < best[0];
    }
    free(scratch);
}

/* The operators transposed, zero-padded and blocked as rom_frozen.h's RomFrozenModel describes. */
static RomStatus frozen_load(RomModel *m, const unsigned char *cursor, uint64_t doubles, char *message,
                             size_t message_size) {
    if (!m || !cursor) return rom_fail(message, message_size, "resources: no model or no body");
    RomFrozenModel *fm = (RomFrozenModel *)calloc(1, sizeof(RomFrozenModel));
    if (!fm) {
        return rom_fail(message, message_size, "resources: out of memory (%llu values)", (unsigned long long)doubles);
    }
    m->body = fm;
    fm->integrator = rom_get_u32(cursor + ROM_FROZEN_HEAD_INTEGRATOR);        /* checked by frozen_read_head */
    fm->n_pairs = rom_get_u32(cursor + ROM_FROZEN_HEAD_N_PAIRS);
    fm->n_freeze_default = rom_get_u32(cursor + ROM_FROZEN_HEAD_N_FREEZE_DEFAULT);
    fm->dt = rom_get_f64(cursor + ROM_FROZEN_HEAD_DT);
    cursor += ROM_FROZEN_HEAD_SIZE;
    const size_t kv = m->k_v, kr = m->k_rho, np = m->n_probes, npairs = fm->n_pairs;
    fm->nm = (uint32_t)rom_round_up(kv * m->kr_pad, 32);
    fm->kv_quad = (uint32_t)rom_round_up(kv, 4);
    const size_t kvp = m->kv_pad, krp = m->kr_pad;
    const int damping = (m->flags & ROM_FLAG_DAMPING) != 0, input = (m->flags & ROM_FLAG_INPUT) != 0;
    /* the tensor follows a_v0, a_rho0, K, b, D, p in the body; stored by its symmetry when it has it */
    const unsigned char *tensor = cursor + 8 * (kv + kr + kv * kr + kv + (damping ? kv * kv : 0) + (input ? kv : 0));
    const int symmetric = npairs ? tensor_symmetric(tensor, kr, kv) : 0;
    const size_t n_tri = kr * (kr + 1) * (kr + 2) / 6;
    const size_t counts[12] = {kv, kr, kr * kvp, kvp, damping ? kv * kvp : 0, input ? kvp : 0,
                               npairs * fm->nm, np * kv, np * kr, np,
                               symmetric ? n_tri * fm->kv_quad : 0, symmetric ? npairs : 0};
    double **ptrs[12] = {&fm->a_v0, &fm->a_rho0, &fm->Kt, &fm->b, &fm->Dt, &fm->p, &fm->Tt, &fm->Pv, &fm->Prho,
                         &fm->probe_x, &fm->W, &fm->pair_scale};
    fm->storage_ = rom_alloc_arrays(counts, ptrs, 12);
    if (!fm->storage_) {
        return rom_fail(message, message_size, "resources: out of memory (%llu values)", (unsigned long long)doubles);
    }
    m->probe_x = fm->probe_x;
    m->input_width = m->k_v;
    cursor = rom_get_f64s(cursor, fm->a_v0, kv);
    cursor = rom_get_f64s(cursor, fm->a_rho0, kr);
    for (size_t p = 0; p < kv; p++) {                    /* K[p][q] -> Kt[q*kv_pad + p] */
        for (size_t q = 0; q < kr; q++, cursor += 8) fm->Kt[q * kvp + p] = rom_get_f64(cursor);
    }
    cursor = rom_get_f64s(cursor, fm->b, kv);
    if (fm->Dt) {
        for (size_t p = 0; p < kv; p++) {
            for (size_t q = 0; q < kv; q++, cursor += 8) fm->Dt[q * kvp + p] = rom_get_f64(cursor);
        }
    }
    if (fm->p) cursor = rom_get_f64s(cursor, fm->p, kv);
    /* T[k][p][q] is entry i = q*kr_pad + p of pair k's M^T; entries are
     * stored in blocks of 32, each block's pairs contiguous:
     * Tt[(i/32)*n_pairs*32 + k*32 + i%32] */
    if (symmetric) {
        const RomStatus status = symmetric_load(m, fm, cursor, message, message_size);
        if (status != ROM_OK) return status;
    }
    for (size_t k = 0; k < npairs; k++) {
        for (size_t p = 0; p < kr; p++) {
            for (size_t q = 0; q < kv; q++, cursor += 8) {
                const size_t i = q * krp + p;
                fm->Tt[(i / 32) * npairs * 32 + k * 32 + i % 32] = rom_get_f64(cursor);
            }
        }
    }
    cursor = rom_get_f64s(cursor, fm->Pv, np * kv);
    cursor = rom_get_f64s(cursor, fm->Prho, np * kr);
    rom_get_f64s(cursor, fm->probe_x, np);
    if (!rom_arrays_finite(ptrs, counts, 12)) {
        return rom_fail(message, message_size, "resources: non-finite numbers in the operators");
    }
    for (uint32_t j = 0; j < np; j++) {
        const double x = fm->probe_x[j];
        if (x < 0.0 || x > 1.0) {
            return rom_fail(message, message_size, "resources: probe %u at x/L = %g is outside [0, 1]", j + 1, x);
        }
    }
    fm->keep_skip = 1;
    if (symmetric) choose_refresh(m, fm);
    return ROM_OK;
}

RomStatus rom_frozen_refresh(const RomModel *model, int *path, int *skip) {
    if (!model || !model->body || !model->ops || model->ops->kind != ROM_MODEL_FROZEN || !path || !skip) {
        return ROM_FAIL;
    }
    const RomFrozenModel *fm = (const RomFrozenModel *)model->body;
    *path = fm->particles ? 2 : fm->symmetric;
    *skip = fm->keep_skip;
    return ROM_OK;
}

RomStatus rom_frozen_set_refresh(RomModel *model, int path, int skip, char *message, size_t message_size) {
    if (!model || !model->body || !model->ops || model->ops->kind != ROM_MODEL_FROZEN) {
        return rom_fail(message, message_size, "the refresh: not a frozen-coefficient model");
    }
    RomFrozenModel *fm = (RomFrozenModel *)model->body;
    if (path < -1 || path > 2 || (path == 1 && !fm->W) || (path == 2 && !fm->Ur) || (path == 0 && !fm->n_pairs) ||
        skip < -1 || skip > 1) {
        return rom_fail(message, message_size, "the refresh: path %d, skip %d (allowed: path -1, %s%s%s; skip -1, 0, "
                        "1)", path, skip, fm->n_pairs ? "0" : "(no tensor)", fm->W ? ", 1" : " (the tensor has no "
                        "symmetry)", fm->Ur ? ", 2" : " (no particle sections)");
    }
    if (path >= 0) {
        fm->particles = path == 2;
        if (path < 2) fm->symmetric = path;
    }
    if (skip >= 0) fm->keep_skip = skip;
    return ROM_OK;
}

/* The particle refresh from sections PARTUR, PARTGUV, PARTIR0 (all three or none; shapes checked by the loader):
 * when present, the refresh path (packaging put them there where they cost less than the tensor). */
static RomStatus frozen_sections_ready(RomModel *m, char *message, size_t message_size) {
    if (!m || !m->body) return rom_fail(message, message_size, "resources: no model");
    RomFrozenModel *fm = (RomFrozenModel *)m->body;
    const RomSection *ur = rom_section(m, "PARTUR"), *guv = rom_section(m, "PARTGUV"), *ir = rom_section(m, "PARTIR0");
    const int found = (ur != NULL) + (guv != NULL) + (ir != NULL);
    if (found == 0 && fm->n_pairs == 0) {
        return rom_fail(message, message_size, "resources: a frozen model without its refresh tensor (n_pairs = 0) "
                        "needs the particle refresh's sections PARTUR, PARTGUV, PARTIR0");
    }
    if (found == 0) return ROM_OK;
    if (found != 3) {
        return rom_fail(message, message_size, "resources: the particle refresh's sections PARTUR, PARTGUV, PARTIR0 "
                        "come together (%d of 3 present)", found);
    }
    fm->Ur = ur->data;
    fm->GUv = guv->data;
    fm->inv_rho0 = ir->data;
    fm->n_particles = ir->cols;
    fm->particles = 1;
    return ROM_OK;
}

static void frozen_model_free(RomModel *m) {
    if (!m || !m->body) return;
    free(((RomFrozenModel *)m->body)->storage_);
    free(((RomFrozenModel *)m->body)->sym_off);
    free(m->body);
    m->body = NULL;
}

/* ------------------------------------------------------------------------ */
/* parametric models: K = c K_c, b = c b_c, D = d D_d (sections KC, BC, DD)  */
/* ------------------------------------------------------------------------ */

static const char *const FROZEN_SECTIONS[] = {"KC", "BC", "DD", "PARTUR", "PARTGUV", "PARTIR0", NULL};
static const char *const FROZEN_PARAM_SECTIONS[] = {"KC", "BC", NULL};

static void frozen_affine_shape(const RomModel *m, const char *tag, uint32_t *rows, uint32_t *cols) {
    if (!m || !tag || !rows || !cols) return;
    if (strcmp(tag, "KC") == 0) {
        *rows = m->k_v;
        *cols = m->k_rho;
    } else if (strcmp(tag, "BC") == 0) {
        *rows = 1;
        *cols = m->k_v;
    } else {                                             /* DD */
        *rows = m->k_v;
        *cols = m->k_v;
    }
}

/* DD goes with the damping flag, and d varies only with damping */
static RomStatus frozen_check_params(const RomModel *m, const RomSection *params, char *message,
                                     size_t message_size) {
    if (!m || !params) return rom_fail(message, message_size, "resources: no model or no section PARAMS");
    const int damping = (m->flags & ROM_FLAG_DAMPING) != 0;
    if (damping != (rom_section(m, "DD") != NULL)) {
        return rom_fail(message, message_size, "resources: section 'DD' %s (it goes with the damping flag)",
                        damping ? "missing" : "without damping");
    }
    if (params->data[4] != 0.0 && !damping) {
        return rom_fail(message, message_size, "resources: d varies but the model has no damping term");
    }
    return ROM_OK;
}

/* K = c K_c, b = c b_c, D = d D_d (eqs. 2.21, 2.22, 2.24), entry by entry (sphrom.rom.parametric) */
static void frozen_assemble(RomModel *m, RomState *s) {
    if (!m || !s || !m->body) return;
    RomFrozenModel *fm = (RomFrozenModel *)m->body;
    const double c = s->c, d = s->d;
    const size_t kv = m->k_v, kr = m->k_rho, kvp = m->kv_pad;
    const double *Kc = rom_section(m, "KC")->data, *bc = rom_section(m, "BC")->data;
    for (size_t p = 0; p < kv; p++) {
        for (size_t q = 0; q < kr; q++) fm->Kt[q * kvp + p] = c * Kc[p * kr + q];
        fm->b[p] = c * bc[p];
    }
    if (fm->Dt) {
        const double *Dd = rom_section(m, "DD")->data;
        for (size_t p = 0; p < kv; p++) {
            for (size_t q = 0; q < kv; q++) fm->Dt[q * kvp + p] = d * Dd[p * kv + q];
        }
    }
}

/* ------------------------------------------------------------------------ */
/* the state                                                                 */
/* ------------------------------------------------------------------------ */

/* M^T, F; the rates; the pair products */
static RomStatus frozen_state_new(RomState *s) {
    if (!s || !s->model || !s->model->body) return ROM_FAIL;
    const RomModel *m = s->model;
    RomFrozenState *fs = (RomFrozenState *)calloc(1, sizeof(RomFrozenState));
    if (!fs) return ROM_FAIL;
    s->body = fs;
    const size_t counts[7] = {((const RomFrozenModel *)m->body)->nm, m->kv_pad, m->kv_pad, m->kr_pad,
                              ((const RomFrozenModel *)m->body)->n_pairs,
                              (size_t)m->k_rho + 1 + ROM_MAX_PORTS,
                              ((const RomFrozenModel *)m->body)->W ? (size_t)m->k_rho * ((const RomFrozenModel *)
                                                                                        m->body)->kv_quad : 0};
    double **ptrs[7] = {&fs->Mt, &fs->F, &fs->dv, &fs->dr, &fs->S, &fs->last_in, &fs->Ms};
    fs->storage_ = rom_alloc_arrays(counts, ptrs, 7);
    return fs->storage_ ? ROM_OK : ROM_FAIL;
}

static void frozen_state_free(RomState *s) {
    if (!s || !s->body) return;
    free(((RomFrozenState *)s->body)->storage_);
    free(s->body);
    s->body = NULL;
}

/* a^v = scale a_v0, a^rho = a_rho0 (the rest density's coordinates; scale = 1: the model's own numbers bit for
 * bit, 1 x a = a) */
static void frozen_initial_state(RomState *s) {
    if (!s || !s->model->body) return;
    const RomFrozenModel *fm = (const RomFrozenModel *)s->model->body;
    const double scale = s->initial_state_scale;
    for (size_t i = 0; i < s->model->k_v; i++) s->av[i] = scale * fm->a_v0[i];
    memcpy(s->ar, fm->a_rho0, s->model->k_rho * sizeof(double));
}

/* the parameters dt and n_freeze at the model's values; M^T and F are refreshed at the first step */
static void frozen_reset(RomState *s) {
    if (!s || !s->body || !s->model->body) return;
    RomFrozenState *fs = (RomFrozenState *)s->body;
    const RomFrozenModel *fm = (const RomFrozenModel *)s->model->body;
    fs->dt = fm->dt;
    fs->n_freeze = (int32_t)fm->n_freeze_default;
    fs->refreshed = 0;
    memset(fs->Mt, 0, (size_t)((const RomFrozenModel *)s->model->body)->nm * sizeof(double));
    memset(fs->F, 0, s->model->kv_pad * sizeof(double));
}

/* ------------------------------------------------------------------------ */
/* the parameters of the internal step: dt, n_freeze                         */
/* ------------------------------------------------------------------------ */

/* The smallest internal step the state accepts: the model's dt x ROM_DT_FLOOR_RATIO, never below ROM_DT_MIN
 * (the work of a doStep grows as 1/dt, rom.h) */
static double frozen_dt_floor(const RomModel *m) {
    if (!m || !m->body) return ROM_DT_MIN;
    return fmax(ROM_DT_MIN, ((const RomFrozenModel *)m->body)->dt * ROM_DT_FLOOR_RATIO);
}

static RomStatus frozen_set_dt(RomState *s, double dt, char *message, size_t message_size) {
    if (!s || !s->body) return rom_fail(message, message_size, "no state");
    const double floor_dt = frozen_dt_floor(s->model);
    if (dt < floor_dt) {
        return rom_fail(message, message_size, "parameter dt = %g s is below its floor %g s (allowed: dt >= %g s, "
                        "the model's dt %g s x %g)", dt, floor_dt, floor_dt,
                        ((const RomFrozenModel *)s->model->body)->dt, ROM_DT_FLOOR_RATIO);
    }
    ((RomFrozenState *)s->body)->dt = dt;
    return ROM_OK;
}

static RomStatus frozen_set_n_freeze(RomState *s, int32_t n_freeze, char *message, size_t message_size) {
    if (!s || !s->body) return rom_fail(message, message_size, "no state");
    ((RomFrozenState *)s->body)->n_freeze = n_freeze;
    return ROM_OK;
}

static double frozen_dt(const RomState *s) {
    return s && s->body ? ((const RomFrozenState *)s->body)->dt : NAN;
}

static int32_t frozen_n_freeze(const RomState *s) {
    return s && s->body ? ((const RomFrozenState *)s->body)->n_freeze : 0;
}

/* ------------------------------------------------------------------------ */
/* the serialized state: n_freeze, dt, M^T (k_v rows of k_rho), F[k_v]       */
/* ------------------------------------------------------------------------ */

static size_t frozen_state_doubles(const RomModel *m) {
    return m ? 2 + (size_t)m->k_rho * m->k_v + m->k_v : 0;
}

static unsigned char *frozen_state_put(const RomState *s, unsigned char *cursor) {
    if (!s || !s->body || !cursor) return cursor;
    const RomFrozenState *fs = (const RomFrozenState *)s->body;
    const size_t kv = s->model->k_v, kr = s->model->k_rho, krp = s->model->kr_pad;
    const double parameters[2] = {(double)fs->n_freeze, fs->dt};
    cursor = rom_put_f64s(cursor, parameters, 2);
    for (size_t r = 0; r < kv; r++) cursor = rom_put_f64s(cursor, fs->Mt + r * krp, kr);
    return rom_put_f64s(cursor, fs->F, kv);
}

static const unsigned char *frozen_state_get(RomState *s, const unsigned char *cursor) {
    if (!s || !s->body || !cursor) return cursor;
    RomFrozenState *fs = (RomFrozenState *)s->body;
    const size_t kv = s->model->k_v, kr = s->model->k_rho, krp = s->model->kr_pad;
    double parameters[2];
    cursor = rom_get_f64s(cursor, parameters, 2);      /* checked by frozen_state_check */
    fs->n_freeze = (int32_t)parameters[0];
    fs->dt = parameters[1];
    fs->refreshed = 0;                                 /* M and F are the state's, not a refresh of last_in */
    for (size_t r = 0; r < kv; r++) cursor = rom_get_f64s(cursor, fs->Mt + r * krp, kr);
    return rom_get_f64s(cursor, fs->F, kv);
}

/* n_freeze a whole number in [1, INT32_MAX], dt finite and at least its floor */
static RomStatus frozen_state_check(const RomModel *m, const unsigned char *cursor, char *message,
                                    size_t message_size) {
    if (!m || !m->body || !cursor) return rom_fail(message, message_size, "serialized state: no data");
    const double n_freeze = rom_get_f64(cursor), dt = rom_get_f64(cursor + 8);
    if (!(n_freeze >= 1.0 && n_freeze <= (double)INT32_MAX && n_freeze == floor(n_freeze))) {
        return rom_fail(message, message_size, "serialized state: parameter n_freeze = %g is out of range (allowed: "
                        "an integer >= 1)", n_freeze);
    }
    const double floor_dt = frozen_dt_floor(m);
    if (!(isfinite(dt) && dt >= floor_dt)) {          /* the work of a doStep grows as 1/dt (rom.h) */
        return rom_fail(message, message_size, "serialized state: dt = %g s is below its floor %g s or not finite "
                        "(allowed: dt >= %g s, the model's dt %g s x %g)", dt, floor_dt, floor_dt,
                        ((const RomFrozenModel *)m->body)->dt, ROM_DT_FLOOR_RATIO);
    }
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* the table                                                                 */
/* ------------------------------------------------------------------------ */

static void frozen_describe(const RomModel *m, char *out, size_t size) {
    if (!m || !m->body || !out) return;
    const RomFrozenModel *fm = (const RomFrozenModel *)m->body;
    snprintf(out, size, "k_v = %u, k_rho = %u, %u probes, dt = %g s, n_freeze = %u, %s", m->k_v, m->k_rho,
             m->n_probes, fm->dt, fm->n_freeze_default,
             fm->integrator == ROM_INTEGRATOR_SYMPLECTIC ? "symplectic" : "euler");
}

const RomKindOps *rom_frozen_kind(void) {
    static const RomKindOps ops = {
        .describe = frozen_describe,
        .kind = ROM_MODEL_FROZEN,
        .name = "the frozen-coefficient model",
        .short_name = "frozen",
        .k_rho_name = "k_rho",
        .length_subject = "",
        .flags = ROM_FLAG_DAMPING | ROM_FLAG_INPUT,
        .min_k_rho = frozen_min_k_rho,
        .head_size = ROM_FROZEN_HEAD_SIZE,
        .read_head = frozen_read_head,
        .load = frozen_load,
        .model_free = frozen_model_free,
        .sections_ready = frozen_sections_ready,
        .sections = FROZEN_SECTIONS,
        .param_sections = FROZEN_PARAM_SECTIONS,
        .affine_shape = frozen_affine_shape,
        .check_params = frozen_check_params,
        .state_new = frozen_state_new,
        .state_free = frozen_state_free,
        .initial_state = frozen_initial_state,
        .reset = frozen_reset,
        .step = frozen_step,
        .advance = frozen_advance,
        .step_exceeds = frozen_step_exceeds,
        .step_work = frozen_step_work,
        .dt_floor = frozen_dt_floor,
        .set_dt = frozen_set_dt,
        .set_n_freeze = frozen_set_n_freeze,
        .dt = frozen_dt,
        .n_freeze = frozen_n_freeze,
        .v_probe = frozen_v_probe,
        .rho_probe = frozen_rho_probe,
        .density_with_channel = 0,          /* rom.c adds the port channel's density shift */
        .check_probe = NULL,
        .v_rate = NULL,
        .rho_rate = NULL,
        .no_rates = "the frozen model provides no output derivatives (maxOutputDerivativeOrder = 0: its "
                    "trajectory is a discrete map of internal steps)",
        .envelope = 1,
        .assemble = frozen_assemble,
        .state_doubles = frozen_state_doubles,
        .state_check = frozen_state_check,
        .state_put = frozen_state_put,
        .state_get = frozen_state_get,
        .expm_count = NULL,
        .linear_name = NULL,
    };
    return &ops;
}
