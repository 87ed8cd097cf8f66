/*
 * The exact linear reduced model in the specific volume
 * (harness/rom/exact_linear.py): dz/dt = A z + B f, advanced over each step by
 * the matrix exponential of its augmented matrix (cached per step length), and
 * for a skew A the free response e^{At} z0 from the real Schur form, evaluated
 * at the time itself so that no error accumulates over steps.
 */
#include "rom_internal.h"

#define ROM_TAYLOR_DEGREE 16            /* ||X||_1 <= 1/2: remainder < 0.5^17/17! ~ 2e-20 */
#define ROM_TAYLOR_NORM 0.5
#define ROM_MAX_SQUARINGS 1100

static double norm1(size_t n, const double *M) {
    double best = 0.0;
    for (size_t j = 0; j < n; j++) {
        double sum = 0.0;
        for (size_t i = 0; i < n; i++) sum += fabs(M[i * n + j]);
        if (!(sum <= best)) best = sum;          /* NaN propagates */
    }
    return best;
}

static void matmul(size_t n, const double *restrict A, const double *restrict B, double *restrict C) {
    for (size_t i = 0; i < n * n; i++) C[i] = 0.0;
    for (size_t i = 0; i < n; i++) {
        for (size_t l = 0; l < n; l++) {
            const double a = A[i * n + l];
            if (a == 0.0) continue;
            const double *restrict row = B + l * n;
            double *restrict out = C + i * n;
            for (size_t j = 0; j < n; j++) out[j] += a * row[j];
        }
    }
}

/* E = e^M (n x n, row-major) by scaling and squaring with a Taylor polynomial
 * (Horner form) on M / 2^s, ||M / 2^s||_1 <= 1/2.  X, T: n x n scratch.
 * Returns 0 when M or the result is not finite. */
static int expm_taylor(size_t n, const double *M, double *E, double *X, double *T) {
    const double nrm = norm1(n, M);
    if (!isfinite(nrm)) return 0;
    int squarings = 0;
    if (nrm > ROM_TAYLOR_NORM) squarings = (int)ceil(log2(nrm / ROM_TAYLOR_NORM));
    if (squarings > ROM_MAX_SQUARINGS) return 0;
    const double scale = ldexp(1.0, -squarings);
    for (size_t i = 0; i < n * n; i++) X[i] = M[i] * scale;
    for (size_t i = 0; i < n * n; i++) E[i] = 0.0;
    for (size_t i = 0; i < n; i++) E[i * n + i] = 1.0;
    for (int j = ROM_TAYLOR_DEGREE; j >= 1; j--) {      /* E = I + X E / j */
        matmul(n, X, E, T);
        const double inv = 1.0 / (double)j;
        for (size_t i = 0; i < n * n; i++) E[i] = T[i] * inv;
        for (size_t i = 0; i < n; i++) E[i * n + i] += 1.0;
    }
    for (int q = 0; q < squarings; q++) {
        matmul(n, E, E, T);
        memcpy(E, T, n * n * sizeof(double));
    }
    return rom_all_finite(E, n * n);
}

/* The maps of a step of length h: Phi = e^{A h}, G0, G1 from the exponential
 * of [[A h, B h, 0], [0, 0, 1], [0, 0, 0]] (as harness.rom.exact_linear.propagators),
 * cached per step length (two slots, the least recently used replaced). */
static RomExpCache *exact_maps(RomState *s, double h, char *message, size_t message_size) {
    const RomModel *m = s->model;
    s->clock++;
    for (int c = 0; c < ROM_EXACT_CACHE; c++) {
        if (s->cache[c].h == h) {
            s->cache[c].used = s->clock;
            return &s->cache[c];
        }
    }
    RomExpCache *slot = &s->cache[0];
    for (int c = 1; c < ROM_EXACT_CACHE; c++) {
        if (s->cache[c].used < slot->used) slot = &s->cache[c];
    }
    /* inputs u = (f if B, F_1/area, ..., F_P/area): columns B, port_B[0], ... */
    const size_t ni = rom_linear_inputs(m), k = m->k, n = k + 2 * ni;
    double *M = s->work, *E = M + n * n, *X = E + n * n, *T = X + n * n;
    memset(M, 0, n * n * sizeof(double));
    for (size_t i = 0; i < k; i++) {
        for (size_t j = 0; j < k; j++) M[i * n + j] = m->A[i * k + j] * h;
        if (m->B) M[i * n + k] = m->B[i] * h;
        for (size_t j = 0; j < m->n_ports; j++) M[i * n + k + (m->B ? 1 : 0) + j] = m->port_B[j * k + i] * h;
    }
    for (size_t c = 0; c < ni; c++) M[(k + c) * n + k + ni + c] = 1.0;
    slot->h = 0.0;
    if (!expm_taylor(n, M, E, X, T)) {
        rom_fail(message, message_size, "the matrix exponential for the step %g s is not finite (step too long for "
                 "this model)", h);
        return NULL;
    }
    s->n_expm++;
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
    slot->used = s->clock;
    return slot;
}

/* z = e^{A t} z0 from the real Schur form A = Q S Q^T (skew A: S has 2x2
 * rotation blocks [[0, w], [-w, 0]] and zeros), evaluated at t directly. */
static void free_response(const RomModel *m, double t, double *restrict y, double *restrict z) {
    const size_t k = m->k;
    size_t i = 0;
    while (i < k) {
        if (i + 1 < k && m->S[(i + 1) * k + i] != 0.0) {
            const double w = m->S[i * k + i + 1];
            const double cs = cos(w * t), sn = sin(w * t);
            const double a = m->y0[i], b = m->y0[i + 1];
            y[i] = cs * a + sn * b;
            y[i + 1] = -sn * a + cs * b;
            i += 2;
        } else {
            y[i] = m->y0[i];
            i += 1;
        }
    }
    for (size_t r = 0; r < k; r++) {
        double acc = 0.0;
        const double *row = m->Q + r * k;
        for (size_t c = 0; c < k; c++) acc += row[c] * y[c];
        z[r] = acc;
    }
}

/* One exact step from t_comm over h: X <- Phi X + G0 f + G1 (rate h); z = free(t - t0) + X
 * (or X).  On failure the state keeps its last good values (the time stays t_comm). */
static RomStatus exact_step(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    const RomModel *m = s->model;
    const size_t k = m->k, kv = m->k_v;
    const RomExpCache *c = exact_maps(s, h, message, message_size);
    if (!c) return ROM_FAIL;
    const size_t ni = rom_linear_inputs(m), n = k + 2 * (ni > 1 ? ni : 1);
    double *xn = s->work + 4 * n * n, *z = xn + k;
    const double f = s->f, df = s->aux[1] * h;
    for (size_t i = 0; i < k; i++) {
        double acc = 0.0;
        const double *row = c->Phi + i * k;
        for (size_t j = 0; j < k; j++) acc += row[j] * s->X[j];
        if (m->B) acc = acc + c->G0[i * ni] * f + c->G1[i * ni] * df;
        for (size_t j = 0; j < m->n_ports; j++) {    /* port forces, held or linear (rate) over the step */
            const size_t col = i * ni + (m->B ? 1 : 0) + j;
            acc = acc + c->G0[col] * (s->port_force[j] / s->area) + c->G1[col] * (s->port_rate[j] * h / s->area);
        }
        xn[i] = acc;
    }
    const double t_new = t_comm + h;
    if (m->Q) {
        double *y = s->work;             /* the exponential's scratch is free again */
        free_response(m, t_new - s->aux[0], y, z);
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
    memcpy(s->X, xn, k * sizeof(double));
    memcpy(s->av, z, kv * sizeof(double));
    memcpy(s->ar, z + kv, m->k_rho * sizeof(double));
    s->n++;
    s->time = t_new;
    return ROM_OK;
}

RomStatus rom_exact_step(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    /* one exact step over h whatever dt is: the input held (or linear) over it */
    if (s->n == INT64_MAX) return rom_fail(message, message_size, "step counter overflow");
    return exact_step(s, t_comm, h, message, message_size);
}

RomStatus rom_exact_advance(RomState *s, int64_t n_steps, char *message, size_t message_size) {
    for (int64_t j = 0; j < n_steps; j++) {
        if (exact_step(s, s->time, s->dt, message, message_size) != ROM_OK) return ROM_FAIL;
    }
    return ROM_OK;
}

/* row . z over the whole state z = (a; b), in the order of z (a row that is zero over one block adds
 * zeros to an exact +0 start or to the sum: the value over the other block, bit for bit) */
double rom_exact_output(const RomState *s, const double *row) {
    const RomModel *m = s->model;
    const size_t kv = m->k_v, ke = m->k_rho;
    double acc = 0.0;
    for (size_t q = 0; q < kv; q++) acc += row[q] * s->av[q];
    for (size_t q = 0; q < ke; q++) acc += row[kv + q] * s->ar[q];
    return acc;
}

/* rho = sum_m pw[j][m] rho0[j][m] / J_m, J = 1 + e at the probe's two particles */
double rom_exact_rho_probe(const RomState *s, uint32_t j) {
    const RomModel *m = s->model;
    double rho = 0.0;
    for (int side = 0; side < 2; side++) {
        const double e = rom_exact_output(s, m->Pe + ((size_t)j * 2 + (size_t)side) * m->k);
        const double J = 1.0 + e;
        if (!(J > 0)) return NAN;                     /* compressed through J = 0: no density */
        rho += m->pw[2 * j + side] * (m->prho0[2 * j + side] / J);
    }
    return rho;
}

double rom_exact_probe_J(const RomState *s, uint32_t j) {
    const RomModel *m = s->model;
    double smallest = INFINITY;
    for (int side = 0; side < 2; side++) {
        const double J = 1.0 + rom_exact_output(s, m->Pe + ((size_t)j * 2 + (size_t)side) * m->k);
        if (!isfinite(J)) return NAN;
        if (J < smallest) smallest = J;
    }
    return smallest;
}

void rom_exact_prepare(RomModel *m) {
    if (!m->Q) return;
    const size_t k = m->k;
    for (size_t i = 0; i < k; i++) {             /* y0 = Q^T z0 */
        double acc = 0.0;
        for (size_t r = 0; r < k; r++) acc += m->Q[r * k + i] * m->z0[r];
        m->y0[i] = acc;
    }
}

/* (dz/dt)_q = sum_c A[q][c] z_c + B[q] f, z = (a; b) the state now, f the input now */
static double state_rate(const RomState *s, size_t q) {
    const RomModel *m = s->model;
    const size_t k = m->k, kv = m->k_v;
    const double *row = m->A + q * k;
    double acc = 0.0;
    for (size_t c = 0; c < kv; c++) acc += row[c] * s->av[c];
    for (size_t c = kv; c < k; c++) acc += row[c] * s->ar[c - kv];
    if (m->B) acc += m->B[q] * s->f;
    return acc;
}

/* the rate of the output row over z: sum_q row[q] (dz/dt)_q */
static double row_rate(const RomState *s, const double *row) {
    double rate = 0.0;
    for (size_t q = 0; q < s->model->k; q++) rate += row[q] * state_rate(s, q);
    return rate;
}

double rom_exact_v_rate(const RomState *s, uint32_t j) {
    return row_rate(s, s->model->Pv + (size_t)j * s->model->k);
}

/* d/dt sum_m pw rho0 / J_m = -sum_m pw rho0 (dJ_m/dt) / J_m^2, J_m = 1 + Pe[j][m] . z */
double rom_exact_rho_rate(const RomState *s, uint32_t j) {
    const RomModel *m = s->model;
    double rate = 0.0;
    for (int side = 0; side < 2; side++) {
        const double *row = m->Pe + ((size_t)j * 2 + (size_t)side) * m->k;
        const double J = 1.0 + rom_exact_output(s, row);
        if (!(J > 0)) return NAN;
        rate -= m->pw[2 * j + side] * m->prho0[2 * j + side] * row_rate(s, row) / (J * J);
    }
    return rate;
}
