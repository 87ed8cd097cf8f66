/*
 * Model kind 2, the exact linear reduced model in the specific volume
 * (harness/rom/exact_linear.py), the path of every linear model: dz/dt = A z +
 * B f, advanced over each step by the matrix exponential of its augmented
 * matrix (cached per step length), and for a dense skew A the free response
 * e^{At} z0 from the real Schur form, evaluated at the time itself so that no
 * error accumulates over steps; a block-diagonal A (the default, flag blocks)
 * block by block, a skew one's rotations from cos and sin of w h once per step
 * length (its |y| kept to round-off per step, no sincos per step).  Its body of the resources, state, outputs and their
 * rates, parameters and serialized block, and its table of operations
 * (rom_exact_kind, at the end).
 */
#include "rom_exact.h"
#include "rom_numerics.h"

#include <stdio.h>
#include <stdlib.h>

/* inputs of the model: f (when B is present), then the port forces (none with the port channel, which takes them) */
static size_t exact_inputs(const RomModel *m) {
    return (((const RomExactModel *)m->body)->B ? 1u : 0u) + rom_port_inputs(m);
}

/* The size of the block of a block-diagonal A starting at row i: 2 where A[i+1][i] != 0, else 1 */
static size_t block_size(const RomExactModel *em, size_t i) {
    return (i + 1 < em->k && em->A[(i + 1) * em->k + i] != 0.0) ? 2 : 1;
}

/* The maps of one block (rows and columns lo .. lo + b - 1) of a block-diagonal A: the exponential of its own
 * augmented matrix [[A_b h, B_b h, 0], [0, 0, I], [0, 0, 0]] (the rest of Phi is zero) */
static int block_maps(const RomModel *m, const RomExactModel *em, RomExpCache *slot, size_t lo, size_t b, double h,
                      double *work) {
    const size_t k = em->k, ni = exact_inputs(m), n = b + 2 * ni;
    double *M = work, *E = M + n * n, *X = E + n * n, *T = X + n * n;
    memset(M, 0, n * n * sizeof(double));
    for (size_t i = 0; i < b; i++) {
        for (size_t j = 0; j < b; j++) M[i * n + j] = em->A[(lo + i) * k + lo + j] * h;
        if (em->B) M[i * n + b] = em->B[lo + i] * h;
        for (size_t j = 0; j < rom_port_inputs(m); j++) {
            M[i * n + b + (em->B ? 1 : 0) + j] = m->port_B[j * k + lo + i] * h;
        }
    }
    for (size_t c = 0; c < ni; c++) M[(b + c) * n + b + ni + c] = 1.0;
    if (!rom_expm_taylor(n, M, E, X, T)) return 0;
    const double *a = em->A + lo * k + lo;
    if (!em->damping && b == 2) {          /* a rotation [[0, w], [-w, 0]]: e^{A h} from cos and sin of w h (a
                                            * rotation to round-off, so that stepping it keeps |y|, the energy) */
        const double c = cos(a[1] * h), sn = sin(a[1] * h);
        E[0] = c;
        E[1] = sn;
        E[n] = -sn;
        E[n + 1] = c;
    }
    for (size_t i = 0; i < b; i++) {
        for (size_t j = 0; j < b; j++) slot->Phi[(lo + i) * k + lo + j] = E[i * n + j];
        for (size_t c = 0; c < ni; c++) {
            slot->G0[(lo + i) * ni + c] = E[i * n + b + c];
            slot->G1[(lo + i) * ni + c] = E[i * n + b + ni + c];
        }
    }
    return 1;
}

/* The maps of a step of length h: Phi = e^{A h}, G0, G1 from the exponential
 * of [[A h, B h, 0], [0, 0, 1], [0, 0, 0]] (as sphrom.rom.exact_linear.propagators),
 * cached per step length (two slots, the least recently used replaced; rom_same_step); a block-diagonal A
 * block by block. */
static RomExpCache *exact_maps(RomState *s, double h, char *message, size_t message_size) {
    const RomModel *m = s->model;
    const RomExactModel *em = (const RomExactModel *)m->body;
    RomExactState *es = (RomExactState *)s->body;
    es->clock++;
    for (int c = 0; c < ROM_EXACT_CACHE; c++) {
        if (rom_same_step(h, es->cache[c].h)) {     /* (an importer's jitter of a few ulps: the same step) */
            es->cache[c].used = es->clock;
            return &es->cache[c];
        }
    }
    RomExpCache *slot = &es->cache[0];
    for (int c = 1; c < ROM_EXACT_CACHE; c++) {
        if (es->cache[c].used < slot->used) slot = &es->cache[c];
    }
    /* inputs u = (f if B, F_1/area, ..., F_P/area): columns B, port_B[0], ... */
    const size_t ni = exact_inputs(m), k = em->k, n = k + 2 * ni;
    if (em->blocks) {
        slot->h = 0.0;
        memset(slot->Phi, 0, k * k * sizeof(double));
        if (ni == 0) {
            memset(slot->G0, 0, k * sizeof(double));
            memset(slot->G1, 0, k * sizeof(double));
        }
        for (size_t lo = 0; lo < k;) {
            const size_t b = block_size(em, lo);
            if (!block_maps(m, em, slot, lo, b, h, es->work)) {
                rom_fail(message, message_size, "the matrix exponential for the step %g s is not finite (step too "
                         "long for this model)", h);
                return NULL;
            }
            lo += b;
        }
        es->n_expm++;
        slot->h = h;
        slot->used = es->clock;
        return slot;
    }
    double *M = es->work, *E = M + n * n, *X = E + n * n, *T = X + n * n;
    memset(M, 0, n * n * sizeof(double));
    for (size_t i = 0; i < k; i++) {
        for (size_t j = 0; j < k; j++) M[i * n + j] = em->A[i * k + j] * h;
        if (em->B) M[i * n + k] = em->B[i] * h;
        for (size_t j = 0; j < rom_port_inputs(m); j++) M[i * n + k + (em->B ? 1 : 0) + j] = m->port_B[j * k + i] * h;
    }
    for (size_t c = 0; c < ni; c++) M[(k + c) * n + k + ni + c] = 1.0;
    slot->h = 0.0;
    if (!rom_expm_taylor(n, M, E, X, T)) {
        rom_fail(message, message_size, "the matrix exponential for the step %g s is not finite (step too long for "
                 "this model)", h);
        return NULL;
    }
    es->n_expm++;
    for (size_t i = 0; i < k; i++) {
        memcpy(slot->Phi + i * k, E + i * n, k * sizeof(double));
        if (ni == 0) {
            slot->G0[i] = 0.0;
            slot->G1[i] = 0.0;
        }
        for (size_t c = 0; c < ni; c++) {            /* G0, G1: [k][ni] */
            slot->G0[i * ni + c] = E[i * n + k + c];
            slot->G1[i * ni + c] = E[i * n + k + ni + c];
        }
    }
    slot->h = h;
    slot->used = es->clock;
    return slot;
}

/* z = e^{A t} z0 from the real Schur form A = Q S Q^T (skew A: S has 2x2
 * rotation blocks [[0, w], [-w, 0]] and zeros), evaluated at t directly (a block-diagonal A steps its rotations
 * instead: no free path; without Q, S is A itself and z = y). */
static void free_response(const RomExactModel *em, double t, double *restrict y, double *restrict z) {
    const size_t k = em->k;
    const double *S = em->Q ? em->S : em->A;
    size_t i = 0;
    while (i < k) {
        if (i + 1 < k && S[(i + 1) * k + i] != 0.0) {
            const double w = S[i * k + i + 1];
            const double cs = cos(w * t), sn = sin(w * t);
            const double a = em->y0[i], b = em->y0[i + 1];
            y[i] = cs * a + sn * b;
            y[i + 1] = -sn * a + cs * b;
            i += 2;
        } else {
            y[i] = em->y0[i];
            i += 1;
        }
    }
    if (!em->Q) {
        memcpy(z, y, k * sizeof(double));
        return;
    }
    for (size_t r = 0; r < k; r++) {
        double acc = 0.0;
        const double *row = em->Q + r * k;
        for (size_t c = 0; c < k; c++) acc += row[c] * y[c];
        z[r] = acc;
    }
}

/* One exact step from t_comm over h: X <- Phi X + G0 f + G1 (rate h); z = free(elapsed + h) + X
 * (or X), the free response at the time since the start (exact at any start time).  On failure the state keeps
 * its last good values (the time stays t_comm). */
static RomStatus exact_step(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    const RomModel *m = s->model;
    const RomExactModel *em = (const RomExactModel *)m->body;
    RomExactState *es = (RomExactState *)s->body;
    const size_t k = em->k, kv = m->k_v;
    const RomExpCache *c = exact_maps(s, h, message, message_size);
    if (!c) return ROM_FAIL;
    const size_t ni = exact_inputs(m), n = k + 2 * (ni > 1 ? ni : 1);
    double *xn = es->work + 4 * n * n, *z = xn + k;
    const double f = s->f, df = s->f_rate * h;
    size_t lo = 0, hi = k;                           /* the columns of row i's block (all of them when dense) */
    for (size_t i = 0; i < k; i++) {
        if (em->blocks && i == hi) lo = hi;
        if (em->blocks && i == lo) hi = lo + block_size(em, lo);
        double acc = 0.0;
        const double *row = c->Phi + i * k;
        for (size_t j = lo; j < hi; j++) acc += row[j] * es->X[j];
        if (em->B) acc = acc + c->G0[i * ni] * f + c->G1[i * ni] * df;
        for (size_t j = 0; j < rom_port_inputs(m); j++) {    /* port forces, held or linear (rate) over the step */
            const size_t col = i * ni + (em->B ? 1 : 0) + j;
            acc = acc + c->G0[col] * (s->port_force[j] / s->area) + c->G1[col] * (s->port_rate[j] * h / s->area);
        }
        xn[i] = acc;
    }
    const double t_new = t_comm + h;
    if (em->free_path) {
        double *y = es->work;            /* the exponential's scratch is free again */
        free_response(em, s->elapsed + h, y, z);
        const double scale = s->initial_state_scale;     /* the free response of scale z0 */
        for (size_t i = 0; i < k; i++) z[i] = scale * z[i] + xn[i];
    } else {
        memcpy(z, xn, k * sizeof(double));
    }
    const double bound = m->runaway_bound;
    int ok = 1;
    for (size_t i = 0; i < k; i++) ok &= (fabs(z[i]) <= bound);
    if (!ok) {
        return rom_fail(message, message_size, "the exact reduced state %s at t = %.9g s (step %lld from t = %.9g s)",
                        rom_all_finite(z, k) ? "ran away (|z| above its bound)" : "became non-finite", t_new,
                        (long long)s->n + 1, t_comm);
    }
    memcpy(es->X, xn, k * sizeof(double));
    memcpy(s->av, z, kv * sizeof(double));
    memcpy(s->ar, z + kv, m->k_rho * sizeof(double));
    s->n++;
    s->time = t_new;
    return ROM_OK;
}

static RomStatus exact_step_over(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    /* one exact step over h whatever dt is: the input held (or linear) over it */
    if (!s || !s->body) return rom_fail(message, message_size, "no state");
    if (s->n == INT64_MAX) return rom_fail(message, message_size, "step counter overflow");
    return exact_step(s, t_comm, h, message, message_size);
}

/* ------------------------------------------------------------------------ */
/* outputs and their rates                                                   */
/* ------------------------------------------------------------------------ */

/* row . z over the whole state z = (a; b), in the order of z (a row that is zero over one block adds
 * zeros to an exact +0 start or to the sum: the value over the other block, bit for bit) */
static double exact_output(const RomState *s, const double *row) {
    const size_t kv = s->model->k_v, ke = s->model->k_rho;
    double acc = 0.0;
    for (size_t q = 0; q < kv; q++) acc += row[q] * s->av[q];
    for (size_t q = 0; q < ke; q++) acc += row[kv + q] * s->ar[q];
    return acc;
}

/* the e row over z of side m (0, 1) of probe j */
static const double *e_row(const RomExactModel *em, uint32_t j, int side) {
    return em->Pe + ((size_t)j * 2 + (size_t)side) * em->k;
}

static double exact_v_probe(const RomState *s, uint32_t j) {
    if (!s || !s->model->body) return NAN;
    const RomExactModel *em = (const RomExactModel *)s->model->body;
    return exact_output(s, em->Pv + (size_t)j * em->k);
}

/* the port channel's e at side m of probe j (rom_port.c; 0 without the channel): the linear model superposes it */
static double channel_e(const RomState *s, uint32_t j, int side) {
    return s->channel ? rom_channel_row(s, s->model->n_probes + 2 * j + (uint32_t)side, NULL) : 0.0;
}

/* rho = sum_m pw[j][m] rho0[j][m] / J_m, J = 1 + e at the probe's two particles (e with the port channel's) */
static double exact_rho_probe(const RomState *s, uint32_t j) {
    if (!s || !s->model->body) return NAN;
    const RomExactModel *em = (const RomExactModel *)s->model->body;
    double rho = 0.0;
    for (int side = 0; side < 2; side++) {
        const double e = exact_output(s, e_row(em, j, side)) + channel_e(s, j, side);
        const double J = 1.0 + e;
        if (!(J > 0) || !isfinite(J)) return NAN;    /* compressed through J = 0 (or no J): no density */
        rho += em->pw[2 * j + side] * (em->prho0[2 * j + side] / J);
    }
    return rho;
}

/* the smaller J = 1 + e of the probe's two particles (NaN when not finite) */
static double probe_J(const RomState *s, uint32_t j) {
    const RomExactModel *em = (const RomExactModel *)s->model->body;
    double smallest = INFINITY;
    for (int side = 0; side < 2; side++) {
        const double J = 1.0 + exact_output(s, e_row(em, j, side)) + channel_e(s, j, side);
        if (!isfinite(J)) return NAN;
        if (J < smallest) smallest = J;
    }
    return smallest;
}

/* J > 0 at the probe: a J <= 0 is named as such, not as a NaN density */
static RomStatus exact_check_probe(const RomState *s, uint32_t j, char *message, size_t message_size) {
    if (!s || !s->model->body) return rom_fail(message, message_size, "no state");
    const double J = probe_J(s, j);
    if (!(J > 0)) {
        return rom_fail(message, message_size, "specific volume J = 1 + e = %g <= 0 at probe %u (x/L = %g) "
                        "at t = %.9g s: compression beyond the model's range", J, j + 1, s->model->probe_x[j],
                        s->time);
    }
    return ROM_OK;
}

/* (dz/dt)_q = sum_c A[q][c] z_c + B[q] f, z = (a; b) the state now, f the input now */
static double state_rate(const RomState *s, size_t q) {
    const RomModel *m = s->model;
    const RomExactModel *em = (const RomExactModel *)m->body;
    const size_t k = em->k, kv = m->k_v;
    const double *row = em->A + q * k;
    double acc = 0.0;
    for (size_t c = 0; c < kv; c++) acc += row[c] * s->av[c];
    for (size_t c = kv; c < k; c++) acc += row[c] * s->ar[c - kv];
    if (em->B) acc += em->B[q] * s->f;
    return acc;
}

/* the rate of the output row over z: sum_q row[q] (dz/dt)_q */
static double row_rate(const RomState *s, const double *row) {
    const size_t k = ((const RomExactModel *)s->model->body)->k;
    double rate = 0.0;
    for (size_t q = 0; q < k; q++) rate += row[q] * state_rate(s, q);
    return rate;
}

static double exact_v_rate(const RomState *s, uint32_t j) {
    if (!s || !s->model->body) return NAN;
    const RomExactModel *em = (const RomExactModel *)s->model->body;
    return row_rate(s, em->Pv + (size_t)j * em->k);
}

/* d/dt sum_m pw rho0 / J_m = -sum_m pw rho0 (dJ_m/dt) / J_m^2, J_m = 1 + Pe[j][m] . z */
static double exact_rho_rate(const RomState *s, uint32_t j) {
    if (!s || !s->model->body) return NAN;
    const RomExactModel *em = (const RomExactModel *)s->model->body;
    double rate = 0.0;
    for (int side = 0; side < 2; side++) {
        const double *row = e_row(em, j, side);
        const double J = 1.0 + exact_output(s, row) + channel_e(s, j, side);
        if (!(J > 0)) return NAN;
        const double dJ = row_rate(s, row) +
                          (s->channel ? rom_channel_row_rate(s, s->model->n_probes + 2 * j + (uint32_t)side) : 0.0);
        rate -= em->pw[2 * j + side] * em->prho0[2 * j + side] * dJ / (J * J);
    }
    return rate;
}

/* ------------------------------------------------------------------------ */
/* resources: the header's rules, the body                                   */
/* ------------------------------------------------------------------------ */

/* with output rows over z the state need not split: k_e may be 0 (the balanced model's k_v = k) */
static uint32_t exact_min_k_rho(const RomHeader *h) {
    return (h && (h->flags & ROM_FLAG_OUTPUT_ROWS)) ? 0u : 1u;
}

/* no header of its own: z0, A, B, Q, S, Pv, Pe, pw, prho0, probe_x follow the shared header */
static RomStatus exact_read_head(const RomHeader *h, const unsigned char *head, uint64_t *doubles, char *message,
                                 size_t message_size) {
    (void)head;
    if (!h || !doubles) return rom_fail(message, message_size, "resources: no header");
    const uint64_t kv = h->k_v, kr = h->k_rho, np = h->n_probes;
    const uint64_t k = kv + kr, schur = (h->flags & ROM_FLAG_SCHUR) ? k * k : 0;
    const int input = (h->flags & ROM_FLAG_INPUT) != 0;
    const int rows = (h->flags & ROM_FLAG_OUTPUT_ROWS) != 0;       /* Pv, Pe over z, or over a, b */
    *doubles = k + k * k + (input ? k : 0) + 2 * schur + np * (rows ? k : kv) + np * 2 * (rows ? k : kr) + 4 * np + np;
    return ROM_OK;
}

/* The arrays as stored (row-major); the probe rows over z (rom.h's format, bit3) */
static RomStatus exact_load(RomModel *m, const unsigned char *cursor, uint64_t doubles, char *message,
                            size_t message_size) {
    if (!m || !cursor) return rom_fail(message, message_size, "resources: no model or no body");
    RomExactModel *em = (RomExactModel *)calloc(1, sizeof(RomExactModel));
    if (!em) {
        return rom_fail(message, message_size, "resources: out of memory (%llu values)", (unsigned long long)doubles);
    }
    m->body = em;
    const size_t kv = m->k_v, ke = m->k_rho, np = m->n_probes, k = (size_t)kv + ke;
    em->k = (uint32_t)k;
    const size_t cB = (m->flags & ROM_FLAG_INPUT) ? k : 0, cQ = (m->flags & ROM_FLAG_SCHUR) ? k * k : 0;
    const int blocks = (m->flags & ROM_FLAG_BLOCKS) != 0, skew = !(m->flags & ROM_FLAG_DAMPING);
    if (blocks && (cQ || !(m->flags & ROM_FLAG_OUTPUT_ROWS))) {
        return rom_fail(message, message_size, "resources: a block-diagonal linear model (flag blocks) has output "
                        "rows over z and no Schur form");
    }
    em->blocks = blocks;
    em->damping = !skew;
    em->free_path = cQ != 0;     /* skew blocks step their rotations (block_maps): no sincos per step */
    const size_t counts[11] = {k, k * k, cB, cQ, cQ, em->free_path ? k : 0, np * k, np * 2 * k, 2 * np, 2 * np, np};
    double **ptrs[11] = {&em->z0, &em->A, &em->B, &em->Q, &em->S, &em->y0, &em->Pv, &em->Pe, &em->pw, &em->prho0,
                         &em->probe_x};
    em->storage_ = rom_alloc_arrays(counts, ptrs, 11);
    if (!em->storage_) {
        return rom_fail(message, message_size, "resources: out of memory (%llu values)", (unsigned long long)doubles);
    }
    m->probe_x = em->probe_x;
    m->input_width = em->k;
    cursor = rom_get_f64s(cursor, em->z0, k);
    cursor = rom_get_f64s(cursor, em->A, k * k);
    if (em->B) cursor = rom_get_f64s(cursor, em->B, k);
    if (em->Q) {
        cursor = rom_get_f64s(cursor, em->Q, k * k);
        cursor = rom_get_f64s(cursor, em->S, k * k);
    }
    if (m->flags & ROM_FLAG_OUTPUT_ROWS) {
        cursor = rom_get_f64s(cursor, em->Pv, np * k);
        cursor = rom_get_f64s(cursor, em->Pe, np * 2 * k);
    } else {                      /* rows over a (v) and over b (e), stored as rows over z = (a; b) */
        for (size_t j = 0; j < np; j++) cursor = rom_get_f64s(cursor, em->Pv + j * k, kv);
        for (size_t r = 0; r < 2 * np; r++) cursor = rom_get_f64s(cursor, em->Pe + r * k + kv, ke);
    }
    cursor = rom_get_f64s(cursor, em->pw, 2 * np);
    cursor = rom_get_f64s(cursor, em->prho0, 2 * np);
    rom_get_f64s(cursor, em->probe_x, np);
    if (!rom_arrays_finite(ptrs, counts, 11)) {
        return rom_fail(message, message_size, "resources: non-finite numbers in the operators");
    }
    for (uint32_t j = 0; j < np; j++) {
        const double x = em->probe_x[j], w0 = em->pw[2 * j], w1 = em->pw[2 * j + 1];
        if (x < 0.0 || x > 1.0 || w0 < 0.0 || w1 < 0.0 || fabs(w0 + w1 - 1.0) > 1e-12 || !(em->prho0[2 * j] > 0) ||
            !(em->prho0[2 * j + 1] > 0)) {
            return rom_fail(message, message_size, "resources: probe %u: x/L = %g outside [0, 1], or weights %g, "
                            "%g not a convex pair, or rho0 <= 0", j + 1, x, w0, w1);
        }
    }
    if (em->Q) {
        for (size_t i = 0; i < k; i++) {             /* y0 = Q^T z0 */
            double acc = 0.0;
            for (size_t r = 0; r < k; r++) acc += em->Q[r * k + i] * em->z0[r];
            em->y0[i] = acc;
        }
    }
    if (blocks) {           /* A block diagonal: zero outside its 1 x 1 and 2 x 2 blocks (a skew one: rotations) */
        for (size_t lo = 0; lo < k;) {
            const size_t b = block_size(em, lo);
            for (size_t i = lo; i < lo + b; i++) {
                for (size_t j = 0; j < k; j++) {
                    if ((j < lo || j >= lo + b) && em->A[i * k + j] != 0.0) {
                        return rom_fail(message, message_size, "resources: A[%zu][%zu] = %g outside the blocks of a "
                                        "block-diagonal linear model (flag blocks)", i, j, em->A[i * k + j]);
                    }
                }
            }
            const double *a = em->A + lo * k + lo;
            if (skew && (a[0] != 0.0 || (b == 2 && (a[k + 1] != 0.0 || a[1] != -a[k])))) {
                return rom_fail(message, message_size, "resources: block %zu of an undamped block-diagonal linear "
                                "model is not a rotation [[0, w], [-w, 0]]", lo + 1);
            }
            lo += b;
        }
    }
    return ROM_OK;
}

static void exact_model_free(RomModel *m) {
    if (!m || !m->body) return;
    free(((RomExactModel *)m->body)->storage_);
    free(m->body);
    m->body = NULL;
}

/* LINMODEL: "exact POD", "balanced"; "linear" when the resources do not say */
static const char *exact_linear_name(const RomModel *m) {
    if (!m) return NULL;
    const RomSection *id = rom_section(m, "LINMODEL");
    if (!id) return "linear";
    return id->data[0] == ROM_LINEAR_BALANCED ? "balanced" : "exact POD";
}

/* ------------------------------------------------------------------------ */
/* parametric models: A = A_0 + c A_c + d A_d (sections A0, AC, AD)          */
/* ------------------------------------------------------------------------ */

static const char *const EXACT_SECTIONS[] = {"BOUNDS", "LINMODEL", "A0", "AC", "AD", NULL};
static const char *const EXACT_PARAM_SECTIONS[] = {"A0", "AC", "AD", NULL};

static void exact_affine_shape(const RomModel *m, const char *tag, uint32_t *rows, uint32_t *cols) {
    if (!m || !m->body || !tag || !rows || !cols) return;
    *rows = *cols = ((const RomExactModel *)m->body)->k;
}

/* A changes with c and d: no Schur form */
static RomStatus exact_check_params(const RomModel *m, const RomSection *params, char *message,
                                    size_t message_size) {
    if (!m || !params) return rom_fail(message, message_size, "resources: no model or no section PARAMS");
    if (m->flags & (ROM_FLAG_SCHUR | ROM_FLAG_BLOCKS)) {
        return rom_fail(message, message_size, "resources: a parametric linear model with a Schur form or in blocks "
                        "(A changes with c and d)");
    }
    return ROM_OK;
}

/* A = A_0 + c A_c + d A_d, entry by entry (sphrom.rom.parametric); the cached exponentials are emptied */
static void exact_assemble(RomModel *m, RomState *s) {
    if (!m || !s || !m->body || !s->body) return;
    RomExactModel *em = (RomExactModel *)m->body;
    RomExactState *es = (RomExactState *)s->body;
    const double c = s->c, d = s->d;
    const double *A0 = rom_section(m, "A0")->data, *Ac = rom_section(m, "AC")->data;
    const double *Ad = rom_section(m, "AD")->data;
    const size_t kk = (size_t)em->k * em->k;
    for (size_t i = 0; i < kk; i++) em->A[i] = A0[i] + c * Ac[i] + d * Ad[i];
    for (int slot = 0; slot < ROM_EXACT_CACHE; slot++) es->cache[slot].h = 0.0;
}

/* ------------------------------------------------------------------------ */
/* the state                                                                 */
/* ------------------------------------------------------------------------ */

/* the forced part X; the exponential's scratch; the cached maps (one G0, G1 column per input: f and the ports) */
static RomStatus exact_state_new(RomState *s) {
    if (!s || !s->model || !s->model->body) return ROM_FAIL;
    const RomModel *m = s->model;
    RomExactState *es = (RomExactState *)calloc(1, sizeof(RomExactState));
    if (!es) return ROM_FAIL;
    s->body = es;
    const size_t inputs = exact_inputs(m) > 1 ? exact_inputs(m) : 1;
    const size_t k = ((const RomExactModel *)m->body)->k, n = k + 2 * inputs, kk = k * k, ki = k * inputs;
    const size_t counts[2 + 3 * ROM_EXACT_CACHE] = {k, 4 * n * n + 2 * k, kk, ki, ki, kk, ki, ki};
    double **ptrs[2 + 3 * ROM_EXACT_CACHE] = {&es->X, &es->work, &es->cache[0].Phi, &es->cache[0].G0,
                                              &es->cache[0].G1, &es->cache[1].Phi, &es->cache[1].G0,
                                              &es->cache[1].G1};
    es->storage_ = rom_alloc_arrays(counts, ptrs, 2 + 3 * ROM_EXACT_CACHE);
    return es->storage_ ? ROM_OK : ROM_FAIL;
}

static void exact_state_free(RomState *s) {
    if (!s || !s->body) return;
    free(((RomExactState *)s->body)->storage_);
    free(s->body);
    s->body = NULL;
}

/* z = scale z0 (z = 0 is rest: v = 0, e = 0); with the Schur form the forced part X starts at 0 and the free
 * response is scale e^{At} z0 (scale = 1: the model's own numbers bit for bit, 1 x a = a) */
static void exact_initial_state(RomState *s) {
    if (!s || !s->model->body || !s->body) return;
    const RomModel *m = s->model;
    const RomExactModel *em = (const RomExactModel *)m->body;
    RomExactState *es = (RomExactState *)s->body;
    const double scale = s->initial_state_scale;
    for (size_t i = 0; i < m->k_v; i++) s->av[i] = scale * em->z0[i];
    for (size_t i = 0; i < m->k_rho; i++) s->ar[i] = scale * em->z0[m->k_v + i];
    if (em->free_path) {
        memset(es->X, 0, em->k * sizeof(double));           /* forced part; the free response is e^{At} z0 */
    } else {
        for (size_t i = 0; i < em->k; i++) es->X[i] = scale * em->z0[i];
    }
}

/* nothing beyond the initial state: the cached exponentials stay valid */
static void exact_reset(RomState *s) {
    (void)s;
}

/* ------------------------------------------------------------------------ */
/* the serialized state: X[k]                                                */
/* ------------------------------------------------------------------------ */

static size_t exact_state_doubles(const RomModel *m) {
    return m && m->body ? ((const RomExactModel *)m->body)->k : 0;
}

static unsigned char *exact_state_put(const RomState *s, unsigned char *cursor) {
    if (!s || !s->body || !cursor) return cursor;
    return rom_put_f64s(cursor, ((const RomExactState *)s->body)->X, exact_state_doubles(s->model));
}

static const unsigned char *exact_state_get(RomState *s, const unsigned char *cursor) {
    if (!s || !s->body || !cursor) return cursor;
    return rom_get_f64s(cursor, ((RomExactState *)s->body)->X, exact_state_doubles(s->model));
}

static int64_t exact_expm_count(const RomState *s) {
    return s && s->body ? ((const RomExactState *)s->body)->n_expm : 0;
}

/* ------------------------------------------------------------------------ */
/* the table                                                                 */
/* ------------------------------------------------------------------------ */

static void exact_describe(const RomModel *m, char *out, size_t size) {
    snprintf(out, size, "k_v = %u, k_rho = %u, %u probes; the %s model (linear, %u states, advanced by the "
             "matrix exponential%s%s)", m->k_v, m->k_rho, m->n_probes, exact_linear_name(m), m->k_v + m->k_rho,
             (m->flags & ROM_FLAG_BLOCKS) ? ", block by block in its real eigen-coordinates" : "",
             rom_section(m, "BOUNDS") ? "; certified error bounds force_error_bound, initial_state_error_bound"
                                            : "");
}

const RomKindOps *rom_exact_kind(void) {
    static const RomKindOps ops = {
        .describe = exact_describe,
        .kind = ROM_MODEL_EXACT_LINEAR,
        .name = "the exact linear model",
        .short_name = "linear",
        .k_rho_name = "k_e",
        .length_subject = "the exact model with ",
        .flags = ROM_FLAG_DAMPING | ROM_FLAG_INPUT | ROM_FLAG_SCHUR | ROM_FLAG_OUTPUT_ROWS | ROM_FLAG_BLOCKS,
        .min_k_rho = exact_min_k_rho,
        .head_size = 0,
        .read_head = exact_read_head,
        .load = exact_load,
        .model_free = exact_model_free,
        .sections = EXACT_SECTIONS,
        .param_sections = EXACT_PARAM_SECTIONS,
        .affine_shape = exact_affine_shape,
        .check_params = exact_check_params,
        .state_new = exact_state_new,
        .state_free = exact_state_free,
        .initial_state = exact_initial_state,
        .reset = exact_reset,
        .step = exact_step_over,
        .advance = NULL,                 /* no internal step: exact over any communication step */
        .step_exceeds = NULL,
        .step_work = NULL,
        .dt_floor = NULL,
        .set_dt = NULL,
        .set_n_freeze = NULL,
        .dt = NULL,
        .n_freeze = NULL,
        .v_probe = exact_v_probe,
        .rho_probe = exact_rho_probe,
        .density_with_channel = 1,          /* J = 1 + e + the port channel's e */
        .check_probe = exact_check_probe,
        .v_rate = exact_v_rate,
        .rho_rate = exact_rho_rate,
        .no_rates = NULL,
        .envelope = 0,
        .assemble = exact_assemble,
        .state_doubles = exact_state_doubles,
        .state_check = NULL,
        .state_put = exact_state_put,
        .state_get = exact_state_get,
        .expm_count = exact_expm_count,
        .linear_name = exact_linear_name,
    };
    return &ops;
}
