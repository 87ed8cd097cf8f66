/*
 * The port channel (harness/rom/port_channel.py builds it; docs/fmu/ports.md): the full linear SPH's response to
 * the port forces alone, exact in time, superposed on the model kind's outputs.  The full SPH is exactly linear in
 * J, and with a uniform damping d each singular triplet of its coupling K spans an invariant plane; the planes the
 * ports excite (all of them on every built-in scene) are stepped here, each by the exponential of its augmented
 * matrix (cached per step length): O(planes x ports) per step, the outputs O(planes x rows) once per step, when
 * first read (two rows per pass over the planes; the probes' density shifts, the rows' bounds and the kind's own
 * v_port at the step's end likewise once per step, however often they are read).  Planes left out (more than the
 * file keeps) add their static correction (a feedthrough into the e rows) and a certified remainder,
 * sum_j gain_rj V(u_j), V(u) = |u(0)| + the total variation of u.
 *
 * The state of each plane is (p, q): x = sum_i p_i [u_i; 0] + q_i [0; w_i] in energy coordinates.  Arrays are kept
 * per quantity (one array of p, one of q, one per map entry) and zero-padded to a multiple of 16, so that the loops
 * run over 4 planes at a time (16 partial sums per output row); the arithmetic is not the Python reference's order
 * (the channel is compared with it within tolerances, not bit for bit).
 *
 * The wave form (rom.h rom_set_port_impedance): with Z > 0 the port force over a step is held at
 * F = 2 a - Z vbar, vbar the mean port velocity over the step, which is linear in F (the channel's mean per unit
 * held input, M, cached with the maps): (I + Z M / area) F = 2 a - Z (vbar_free + v_own), solved by Gaussian
 * elimination (P <= 4); b = a - F (a master passes it on as the incident wave a of the component at the line's
 * other end, one step later: a lossless line whose delay is the communication step).  An incident wave with a rate
 * (fmi2SetRealInputDerivatives on a_port_j) goes linearly over the step, a(t) = a + adot (t - t_k): the held force
 * is the mean of 2 a(t) - Z v(t) over the step, so a enters as its exact mean over the step, abar = a + adot h / 2
 * (F = 2 abar - Z vbar, b = abar - F, the power F vbar = (abar^2 - b^2) / Z: passive as held), and a continues
 * along its line after the step, as f and F_port do.
 */
#include "rom_internal.h"
#include "rom_numerics.h"

#include <stdio.h>
#include <stdlib.h>

#define CHANNEL_CACHE 2                /* step lengths whose maps are kept */
#define CHANNEL_ROUNDOFF 1e-9          /* harness/rom/port_channel.py ROUNDOFF */
#define CHANNEL_ROUNDOFF_STEP 1e-15    /* ... ROUNDOFF_STEP */
#define CHANNEL_AUG 6                  /* the augmented matrix: p, q, mean p, mean q, u0, du */

/* the entries of one plane's maps (harness/rom/port_channel.py step_maps) */
enum { PHI00, PHI01, PHI10, PHI11, G0P, G0Q, G1P, G1Q, PSIP, PSIQ, PSI0, PSI1, N_MAPS };

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(ROM_NO_CLONES) && (__GNUC__ >= 8)
#define CHANNEL_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define CHANNEL_CLONES
#endif
#if defined(__GNUC__)
typedef double c4d __attribute__((vector_size(32)));    /* one AVX register (two SSE2 ones) */
#define C4_LOAD(ptr) (*(const c4d *)(const void *)(ptr))
#define C4_STORE(ptr, v) (*(c4d *)(void *)(ptr) = (v))
#define C4_SPLAT(x) ((c4d){(x), (x), (x), (x)})
#endif
#if defined(__GNUC__)
#define CHANNEL_INLINE static inline __attribute__((always_inline))    /* into each clone, with its constants */
#else
#define CHANNEL_INLINE static inline
#endif
#if defined(__GNUC__) && !defined(__clang__)
#define CHANNEL_UNROLL _Pragma("GCC unroll 2")       /* the loops over a block's rows: the sums stay in registers */
#else
#define CHANNEL_UNROLL
#endif
#define ROW_BLOCK 2                    /* output rows summed in one pass over the planes (dot_rows) */

typedef struct {
    double h;                  /* 0: empty */
    int64_t used;
    double *map[N_MAPS];       /* [pad] each */
    double M[ROM_MAX_PORTS * ROM_MAX_PORTS];   /* mean v_port_j over the step per unit held u_l */
} ChannelCache;

typedef struct {
    double *p, *q;             /* [pad] the planes' state */
    double *values;            /* [rows] the rows' plane part, valid when valid != 0 */
    double *certs;             /* [rows] the rows' certified bounds, valid when valid and certs_valid != 0 */
    double *shift;             /* [probes] rom_channel_density_shift, valid when valid != 0 and no plane is
                                * truncated (else it follows the input now, computed when read) */
    int valid, certs_valid;
    double v_kind[ROM_MAX_PORTS];      /* the kind's v_port_j (rom_port_velocity) at the end of the last step, */
    int kind_valid;                    /* kept until the kind's state moves (rom_channel_kind_moved) */
    double tv[ROM_MAX_PORTS];          /* |u(0)| + the total variation of each u_j so far */
    double u_int[ROM_MAX_PORTS];       /* bounds of int |u_j| dt, int tv_j dt and int |w| dt so far: the */
    double tv_int[ROM_MAX_PORTS];      /* decomposition's drift (channel_drift) */
    double w_int;
    double w_norm;             /* |w| of the state now, valid when norm_valid (channel_norm: the drift's and the */
    int norm_valid;            /* certs' one sum per state) */
    double u_prev[ROM_MAX_PORTS];      /* u_j at the end of the last step */
    double steps;              /* steps taken (the round-off allowance) */
    double impedance;          /* the wave form's Z [N s m^-1]; 0: the force form */
    double wave[ROM_MAX_PORTS];        /* a_j [N] */
    double wave_rate[ROM_MAX_PORTS];   /* da_j/dt [N s^-1] (input derivatives; 0: held) */
    double reflected[ROM_MAX_PORTS];   /* b_j [N] after the last step */
    double applied[ROM_MAX_PORTS];     /* the port force held over the last step in the wave form [N] */
    ChannelCache cache[CHANNEL_CACHE];
    int64_t clock;
    double work[4 * CHANNEL_AUG * CHANNEL_AUG];
    void *storage_;
} ChannelState;

/* ------------------------------------------------------------------------ */
/* resources                                                                 */
/* ------------------------------------------------------------------------ */

static const char *const TAGS[] = {"PCSCAL", "PCLAM", "PCB", "PCC", "PCD", "PCPROBE"};
#define N_TAGS (sizeof TAGS / sizeof TAGS[0])

RomStatus rom_channel_check_section(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    (void)m;
    if (!s || s->rows == 0 || s->cols == 0) return rom_fail(message, message_size, "resources: an empty section");
    return ROM_OK;      /* the sizes against each other: rom_channel_prepare, once every section is read */
}

static RomStatus shape(const RomSection *s, uint32_t rows, uint32_t cols, char *message, size_t message_size) {
    if (s->rows != rows || s->cols != cols) {
        return rom_fail(message, message_size, "resources: section %s is %u x %u, expected %u x %u (the port "
                        "channel)", s->tag, s->rows, s->cols, rows, cols);
    }
    return ROM_OK;
}

RomStatus rom_channel_prepare(RomModel *m, char *message, size_t message_size) {
    const RomSection *sec[N_TAGS];
    size_t found = 0;
    for (size_t i = 0; i < N_TAGS; i++) {
        sec[i] = rom_section(m, TAGS[i]);
        if (sec[i]) found++;
    }
    if (found == 0) return ROM_OK;
    if (found != N_TAGS) {
        return rom_fail(message, message_size, "resources: the port channel's sections PCSCAL, PCLAM, PCB, PCC, PCD, "
                        "PCPROBE come together (%zu of %zu present)", found, (size_t)N_TAGS);
    }
    if (!m->n_ports || m->port_B) {
        return rom_fail(message, message_size, "resources: the port channel needs the sections PORTX and PORTC and "
                        "no PORTB (the channel takes every port force)");
    }
    if (shape(sec[0], 1, ROM_PCSCAL_COLUMNS, message, message_size) != ROM_OK) return ROM_FAIL;
    const double *v = sec[0]->data;
    const double planes = v[ROM_PCSCAL_PLANES], truncated = v[ROM_PCSCAL_TRUNCATED], dx = v[ROM_PCSCAL_DX];
    const uint32_t rows = 3u * m->n_probes + m->n_ports;
    if (!(planes >= 1 && planes <= ROM_MAX_MODES && planes == floor(planes)) ||
        v[ROM_PCSCAL_PORTS] != (double)m->n_ports || v[ROM_PCSCAL_ROWS] != (double)rows ||
        !(truncated == 0.0 || truncated == 1.0) || !(dx > 0) ||
        !(v[ROM_PCSCAL_GROWTH] >= 0 && isfinite(v[ROM_PCSCAL_GROWTH]))) {
        return rom_fail(message, message_size, "resources: section PCSCAL (the port channel's sizes) does not fit the "
                        "model (%u ports, %u rows expected; planes 1 to %u; dx > 0; a finite growth >= 0)", m->n_ports,
                        rows, ROM_MAX_MODES);
    }
    RomChannelModel *c = &m->channel;
    const uint32_t n = (uint32_t)planes, P = m->n_ports;
    if (shape(sec[1], n, 4, message, message_size) != ROM_OK || shape(sec[2], n, P, message, message_size) != ROM_OK ||
        shape(sec[3], rows, n, message, message_size) != ROM_OK ||
        shape(sec[4], rows, 4 * P + 1, message, message_size) != ROM_OK ||
        shape(sec[5], m->n_probes, 4, message, message_size) != ROM_OK) return ROM_FAIL;
    for (uint32_t i = 0; i < n; i++) {         /* each block [[-d, s], [-s, 0]], d >= 0: dissipative */
        const double *L = sec[1]->data + 4 * (size_t)i;
        if (!(L[0] <= 0.0 && L[1] == -L[2] && L[3] == 0.0)) {
            return rom_fail(message, message_size, "resources: section PCLAM: plane %u is not [[-d, s], [-s, 0]] with "
                            "d >= 0", i + 1);
        }
    }
    for (uint32_t r = 0; r < rows; r++) {
        for (uint32_t j = P; j < 4 * P + 1; j++) {      /* the remainder's and the drift's gains */
            const double g = sec[4]->data[(size_t)r * (4 * P + 1) + j];
            if (!(g >= 0.0 && isfinite(g))) {
                return rom_fail(message, message_size, "resources: section PCD: a negative or infinite gain of the "
                                "port channel's bound (row %u, column %u; allowed: a finite number >= 0)", r + 1, j + 1);
            }
        }
    }
    const size_t pad = rom_round_up(n, 16);
    double *beta_t, *C_pad, *norms;               /* 64-byte aligned, zeroed: the 4-plane loads, 16 per turn */
    const size_t counts[3] = {(size_t)P * pad, (size_t)rows * pad, rows};
    double **ptrs[3] = {&beta_t, &C_pad, &norms};
    c->storage_ = rom_alloc_arrays(counts, ptrs, 3);
    if (!c->storage_) return rom_fail(message, message_size, "resources: out of memory (the port channel)");
    double beta2 = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        for (uint32_t j = 0; j < P; j++) {
            const double b = sec[2]->data[(size_t)i * P + j];
            beta_t[(size_t)j * pad + i] = b;
            beta2 += b * b;
        }
    }
    c->beta_norm = sqrt(beta2) * (1.0 + 1e-12);   /* (the sum's round-off: n P additions, far below 1e-12) */
    for (uint32_t r = 0; r < rows; r++) {
        double acc = 0.0;
        for (uint32_t i = 0; i < n; i++) {
            const double x = sec[3]->data[(size_t)r * n + i];
            C_pad[(size_t)r * pad + i] = x;
            acc += x * x;
        }
        norms[r] = sqrt(acc);
    }
    c->planes = n;
    c->ports = P;
    c->rows = rows;
    c->pad = (uint32_t)pad;
    c->truncated = truncated != 0.0;
    c->dx = dx;
    c->growth = v[ROM_PCSCAL_GROWTH];
    c->lam = sec[1]->data;
    c->beta = sec[2]->data;
    c->C = sec[3]->data;
    c->D = sec[4]->data;
    c->probe = sec[5]->data;
    c->beta_t = beta_t;
    c->C_pad = C_pad;
    c->row_norm = norms;
    return ROM_OK;
}

int rom_has_channel(const RomModel *m) {
    return m && m->channel.planes > 0;
}

/* ------------------------------------------------------------------------ */
/* the state                                                                 */
/* ------------------------------------------------------------------------ */

RomStatus rom_channel_state_new(RomState *s) {
    const RomChannelModel *c = &s->model->channel;
    s->channel = NULL;
    if (!c->planes) return ROM_OK;
    ChannelState *cs = (ChannelState *)calloc(1, sizeof(ChannelState));
    if (!cs) return ROM_FAIL;
    s->channel = cs;
    enum { FIXED = 5 };
    size_t counts[FIXED + CHANNEL_CACHE * N_MAPS];
    double **ptrs[FIXED + CHANNEL_CACHE * N_MAPS];
    counts[0] = counts[1] = c->pad;
    counts[2] = c->rows;
    counts[3] = s->model->n_probes;
    counts[4] = c->rows;
    ptrs[0] = &cs->p;
    ptrs[1] = &cs->q;
    ptrs[2] = &cs->values;
    ptrs[3] = &cs->shift;
    ptrs[4] = &cs->certs;
    for (int slot = 0; slot < CHANNEL_CACHE; slot++) {
        for (int e = 0; e < N_MAPS; e++) {
            counts[FIXED + slot * N_MAPS + e] = c->pad;
            ptrs[FIXED + slot * N_MAPS + e] = &cs->cache[slot].map[e];
        }
    }
    cs->storage_ = rom_alloc_arrays(counts, ptrs, FIXED + CHANNEL_CACHE * N_MAPS);
    return cs->storage_ ? ROM_OK : ROM_FAIL;
}

void rom_channel_state_free(RomState *s) {
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs) return;
    free(cs->storage_);
    free(cs);
    s->channel = NULL;
}

/* at rest, no input so far, the force form; the cached maps stay valid */
void rom_channel_reset(RomState *s) {
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs) return;
    const RomChannelModel *c = &s->model->channel;
    memset(cs->p, 0, c->pad * sizeof(double));
    memset(cs->q, 0, c->pad * sizeof(double));
    for (uint32_t j = 0; j < ROM_MAX_PORTS; j++) {
        cs->tv[j] = cs->u_prev[j] = cs->wave[j] = cs->wave_rate[j] = cs->reflected[j] = cs->applied[j] = 0.0;
        cs->u_int[j] = cs->tv_int[j] = 0.0;
    }
    cs->w_int = 0.0;
    cs->steps = 0.0;
    cs->impedance = 0.0;
    cs->valid = 0;
    cs->norm_valid = 0;
    cs->kind_valid = 0;
}

/* the kind's state moves (a step, initial_state_scale, rom_advance, a new parameter): its v_port is read anew */
void rom_channel_kind_moved(RomState *s) {
    ChannelState *cs = s ? (ChannelState *)s->channel : NULL;
    if (cs) cs->kind_valid = 0;
}

/* (rom_internal.h; here, not in rom.c, which calls this file: no circle of calls) */
RomStatus rom_check_port_input(const RomState *s, const char *name, uint32_t j, double value, const char *what,
                               char *message, size_t message_size) {
    if (!s || !name) return rom_fail(message, message_size, "no state or no input name");
    if (isfinite(value)) return ROM_OK;
    if (!what) {
        return rom_fail(message, message_size, "input derivative of %s_%u, d%s_%u/dt = %g N s^-1 at t = %.9g s, is not "
                        "finite (allowed: a finite rate)", name, j + 1, name, j + 1, value, s->time);
    }
    return rom_fail(message, message_size, "input %s_%u = %g N at t = %.9g s is not finite (allowed: a finite %s in N)",
                    name, j + 1, value, s->time, what);
}

double rom_channel_kind_velocity(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_ports) return NAN;
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs) return rom_port_velocity(s, j);
    if (!cs->kind_valid) {                 /* every port's once, as rom_do_step does at a step's end */
        for (uint32_t l = 0; l < s->model->n_ports; l++) cs->v_kind[l] = rom_port_velocity(s, l);
        cs->kind_valid = 1;
    }
    return cs->v_kind[j];
}

/* ------------------------------------------------------------------------ */
/* the step                                                                  */
/* ------------------------------------------------------------------------ */

/* The maps of a step h, cached per step length (rom_same_step): per plane the exponential of the augmented matrix
 * over (p, q, mean p, mean q, u0, du) (harness/rom/port_channel.py step_maps), and the wave form's M. */
static const ChannelCache *channel_maps(ChannelState *cs, const RomModel *m, double h) {
    const RomChannelModel *c = &m->channel;
    cs->clock++;
    for (int k = 0; k < CHANNEL_CACHE; k++) {
        if (rom_same_step(h, cs->cache[k].h)) {
            cs->cache[k].used = cs->clock;
            return &cs->cache[k];
        }
    }
    ChannelCache *slot = &cs->cache[0];
    for (int k = 1; k < CHANNEL_CACHE; k++) {
        if (cs->cache[k].used < slot->used) slot = &cs->cache[k];
    }
    enum { A = CHANNEL_AUG };
    double M[A * A], *E = cs->work, *X = E + A * A, *T = X + A * A;
    for (uint32_t i = 0; i < c->planes; i++) {
        const double *L = c->lam + 4 * (size_t)i;
        memset(M, 0, sizeof M);
        M[0 * A + 0] = L[0] * h;
        M[0 * A + 1] = L[1] * h;
        M[1 * A + 0] = L[2] * h;
        M[1 * A + 1] = L[3] * h;
        M[0 * A + 4] = h;                 /* the input enters p */
        M[2 * A + 0] = 1.0;               /* the means: d(mean)/d(tau/h) = the state */
        M[3 * A + 1] = 1.0;
        M[4 * A + 5] = 1.0;               /* u(tau) = u0 + du tau / h */
        if (!rom_expm_taylor(A, M, E, X, T)) {
            for (int e = 0; e < N_MAPS; e++) slot->map[e][i] = NAN;       /* the outputs become NaN: visible */
            continue;
        }
        slot->map[PHI00][i] = E[0 * A + 0];
        slot->map[PHI01][i] = E[0 * A + 1];
        slot->map[PHI10][i] = E[1 * A + 0];
        slot->map[PHI11][i] = E[1 * A + 1];
        slot->map[G0P][i] = E[0 * A + 4];
        slot->map[G0Q][i] = E[1 * A + 4];
        slot->map[G1P][i] = E[0 * A + 5];
        slot->map[G1Q][i] = E[1 * A + 5];
        slot->map[PSIP][i] = E[2 * A + 0];
        slot->map[PSIQ][i] = E[2 * A + 1];
        slot->map[PSI0][i] = E[2 * A + 4];
        slot->map[PSI1][i] = E[2 * A + 5];
    }
    const uint32_t P = c->ports, first = 3u * m->n_probes;
    for (uint32_t j = 0; j < P; j++) {     /* M[j][l] = sum_i C_port_j,i psi0_i beta_il */
        const double *row = c->C + (size_t)(first + j) * c->planes;
        for (uint32_t l = 0; l < P; l++) {
            double acc = 0.0;
            for (uint32_t i = 0; i < c->planes; i++) acc += row[i] * slot->map[PSI0][i] * c->beta[(size_t)i * P + l];
            slot->M[j * P + l] = acc;
        }
    }
    slot->h = h;
    slot->used = cs->clock;
    return slot;
}

/* p, q <- Phi (p, q) + g0 ue + g1 de, plane by plane, the planes' inputs ue_i = sum_j beta_ij u_j and
 * de_i = sum_j beta_ij du_j formed in the same pass (summed over j in order from 0, as a separate pass would); held
 * inputs (every du_j = 0, the common case) skip the g1 terms, which would add exact zeros */
CHANNEL_INLINE void step_planes_n(const RomChannelModel *ch, const ChannelCache *k, double *restrict p,
                                 double *restrict q, const double *u, const double *du, const uint32_t P) {
    const size_t pad = ch->pad;
    const double *restrict a = k->map[PHI00], *restrict b = k->map[PHI01], *restrict c = k->map[PHI10];
    const double *restrict d = k->map[PHI11], *restrict g0p = k->map[G0P], *restrict g0q = k->map[G0Q];
    const double *restrict g1p = k->map[G1P], *restrict g1q = k->map[G1Q];
    const double *restrict b0 = ch->beta_t, *restrict b1 = b0 + (P > 1 ? pad : 0);
    const double *restrict b2 = b0 + (P > 2 ? 2 * pad : 0), *restrict b3 = b0 + (P > 3 ? 3 * pad : 0);
    double uu[ROM_MAX_PORTS] = {0.0}, dd[ROM_MAX_PORTS] = {0.0};
    int ramp = 0;
    for (uint32_t j = 0; j < P; j++) {
        uu[j] = u[j];
        dd[j] = du[j];
        ramp |= du[j] != 0.0;
    }
    const double u0 = uu[0], u1 = uu[1], u2 = uu[2], u3 = uu[3];
    const double d0 = dd[0], d1 = dd[1], d2 = dd[2], d3 = dd[3];
#if defined(__GNUC__)
    /* four planes at a time (pad is a multiple of 16, the arrays 64-byte aligned): the same operations, lane by
     * lane (each plane's arithmetic does not depend on the width) */
    const c4d U0 = C4_SPLAT(u0), U1 = C4_SPLAT(u1), U2 = C4_SPLAT(u2), U3 = C4_SPLAT(u3);
    const c4d D0 = C4_SPLAT(d0), D1 = C4_SPLAT(d1), D2 = C4_SPLAT(d2), D3 = C4_SPLAT(d3);
    for (size_t i = 0; i < pad; i += 4) {
        c4d ue = C4_SPLAT(0.0);
        if (P > 0) ue += C4_LOAD(b0 + i) * U0;
        if (P > 1) ue += C4_LOAD(b1 + i) * U1;
        if (P > 2) ue += C4_LOAD(b2 + i) * U2;
        if (P > 3) ue += C4_LOAD(b3 + i) * U3;
        const c4d pi = C4_LOAD(p + i), qi = C4_LOAD(q + i);
        c4d pn = C4_LOAD(a + i) * pi + C4_LOAD(b + i) * qi + C4_LOAD(g0p + i) * ue;
        c4d qn = C4_LOAD(c + i) * pi + C4_LOAD(d + i) * qi + C4_LOAD(g0q + i) * ue;
        if (ramp) {                        /* de formed only for a ramp: held inputs skip it as the g1 terms */
            c4d de = C4_SPLAT(0.0);
            if (P > 0) de += C4_LOAD(b0 + i) * D0;
            if (P > 1) de += C4_LOAD(b1 + i) * D1;
            if (P > 2) de += C4_LOAD(b2 + i) * D2;
            if (P > 3) de += C4_LOAD(b3 + i) * D3;
            pn += C4_LOAD(g1p + i) * de;
            qn += C4_LOAD(g1q + i) * de;
        }
        C4_STORE(p + i, pn);
        C4_STORE(q + i, qn);
    }
#else
    for (size_t i = 0; i < pad; i++) {
        double ue = 0.0, de = 0.0;
        if (P > 0) { ue += b0[i] * u0; de += b0[i] * d0; }
        if (P > 1) { ue += b1[i] * u1; de += b1[i] * d1; }
        if (P > 2) { ue += b2[i] * u2; de += b2[i] * d2; }
        if (P > 3) { ue += b3[i] * u3; de += b3[i] * d3; }
        const double pi = p[i], qi = q[i];
        if (ramp) {
            p[i] = a[i] * pi + b[i] * qi + g0p[i] * ue + g1p[i] * de;
            q[i] = c[i] * pi + d[i] * qi + g0q[i] * ue + g1q[i] * de;
        } else {
            p[i] = a[i] * pi + b[i] * qi + g0p[i] * ue;
            q[i] = c[i] * pi + d[i] * qi + g0q[i] * ue;
        }
    }
#endif
}

/* step_planes_n with the port count a constant (its loop without a test of P per plane) */
CHANNEL_CLONES
static void step_planes(const RomChannelModel *ch, const ChannelCache *k, double *restrict p, double *restrict q,
                        const double *u, const double *du) {
    switch (ch->ports) {
        case 1: step_planes_n(ch, k, p, q, u, du, 1); break;
        case 2: step_planes_n(ch, k, p, q, u, du, 2); break;
        case 3: step_planes_n(ch, k, p, q, u, du, 3); break;
        default: step_planes_n(ch, k, p, q, u, du, ROM_MAX_PORTS); break;
    }
}

#if !defined(__GNUC__)
/* sum_i row_i x_i over the padded planes (a multiple of 16): sixteen partial sums, lane l holding the i = l mod 16,
 * combined as dot_rows_n combines its registers' lanes (the same bits with or without vector types) */
static double dot(const double *row, const double *x, size_t pad) {
    double acc[16] = {0.0};
    for (size_t i = 0; i < pad; i += 16) {
        for (int j = 0; j < 16; j++) acc[j] += row[i + j] * x[i + j];
    }
    double quad[4];
    for (int l = 0; l < 4; l++) quad[l] = (acc[l] + acc[l + 4]) + (acc[l + 8] + acc[l + 12]);
    return (quad[0] + quad[1]) + (quad[2] + quad[3]);
}
#endif

#if defined(__GNUC__)
/* the sixteen partial sums of a row (its four-lane chains a[0..3], lane l of a[c] holding the i = 4 c + l mod 16)
 * into one: (a0 + a1) + (a2 + a3), then its lanes pairwise */
CHANNEL_INLINE double fold16(const c4d *a) {
    const c4d acc = (a[0] + a[1]) + (a[2] + a[3]);
    return (acc[0] + acc[1]) + (acc[2] + acc[3]);
}
#endif

/* rows[0 .. n-1] (each pad long) times x into out[0 .. n-1], in one pass over x: per row sixteen partial sums in
 * four four-lane chains, lane l of chain c holding the i = 4 c + l mod 16, summed as (a0 + a1) + (a2 + a3), then the
 * lanes pairwise (fold16; dot() without vector types: the same bits).  n is a constant where dot_rows calls it, so
 * that the sums stay in registers */
CHANNEL_INLINE void dot_rows_n(const double *restrict rows, size_t pad, const uint32_t n, const double *restrict x,
                              double *out) {
#if defined(__GNUC__)
    c4d a[ROW_BLOCK][4];
    CHANNEL_UNROLL
    for (uint32_t r = 0; r < n; r++) a[r][0] = a[r][1] = a[r][2] = a[r][3] = C4_SPLAT(0.0);
    for (size_t i = 0; i < pad; i += 16) {
        const c4d x0 = C4_LOAD(x + i), x1 = C4_LOAD(x + i + 4), x2 = C4_LOAD(x + i + 8), x3 = C4_LOAD(x + i + 12);
        CHANNEL_UNROLL
        for (uint32_t r = 0; r < n; r++) {
            const double *row = rows + r * pad + i;
            a[r][0] += C4_LOAD(row) * x0;
            a[r][1] += C4_LOAD(row + 4) * x1;
            a[r][2] += C4_LOAD(row + 8) * x2;
            a[r][3] += C4_LOAD(row + 12) * x3;
        }
    }
    CHANNEL_UNROLL
    for (uint32_t r = 0; r < n; r++) out[r] = fold16(a[r]);
#else
    for (uint32_t r = 0; r < n; r++) out[r] = dot(rows + r * pad, x, pad);
#endif
}

/* |(p, q)|^2 = dot(p, p) + dot(q, q), bit for bit, both sums in one pass (as dot_rows_n forms them) */
CHANNEL_CLONES
static double norm2(const double *restrict p, const double *restrict q, size_t pad) {
#if defined(__GNUC__)
    c4d a[4], b[4];
    a[0] = a[1] = a[2] = a[3] = b[0] = b[1] = b[2] = b[3] = C4_SPLAT(0.0);
    for (size_t i = 0; i < pad; i += 16) {
        const c4d p0 = C4_LOAD(p + i), p1 = C4_LOAD(p + i + 4), p2 = C4_LOAD(p + i + 8), p3 = C4_LOAD(p + i + 12);
        const c4d q0 = C4_LOAD(q + i), q1 = C4_LOAD(q + i + 4), q2 = C4_LOAD(q + i + 8), q3 = C4_LOAD(q + i + 12);
        a[0] += p0 * p0;
        a[1] += p1 * p1;
        a[2] += p2 * p2;
        a[3] += p3 * p3;
        b[0] += q0 * q0;
        b[1] += q1 * q1;
        b[2] += q2 * q2;
        b[3] += q3 * q3;
    }
    return fold16(a) + fold16(b);
#else
    return dot(p, p, pad) + dot(q, q, pad);
#endif
}

/* the drift's integrals over a step h from the state now (before the step), as port_channel.py ChannelState._drift:
 * u linear over the step, so |u_j(t)| <= m_j = max(|u_j|, |u_j + du_j|); each plane's e^{L t} is a contraction
 * (d >= 0), so |w(t)| <= |w(0)| + t |beta|_F |m|; tv_j (already at the step's end) bounds tv_j(t) over it */
static double channel_norm(const RomChannelModel *c, ChannelState *cs) {
    if (!cs->norm_valid) {
        cs->w_norm = sqrt(norm2(cs->p, cs->q, c->pad));
        cs->norm_valid = 1;
    }
    return cs->w_norm;
}

static void channel_drift(const RomChannelModel *c, ChannelState *cs, double h, const double *u, const double *du) {
    double m2 = 0.0;
    for (uint32_t j = 0; j < c->ports; j++) {
        const double m = fmax(fabs(u[j]), fabs(u[j] + du[j]));
        cs->u_int[j] += h * m;
        cs->tv_int[j] += h * cs->tv[j];
        m2 += m * m;
    }
    cs->w_int += h * channel_norm(c, cs) + 0.5 * h * h * c->beta_norm * sqrt(m2);
}

/* dot_rows_n for 1 <= n <= ROW_BLOCK rows (two: eight four-lane sums, in the sixteen AVX registers) */
CHANNEL_CLONES
static void dot_rows(const double *restrict rows, size_t pad, uint32_t n, const double *restrict x, double *out) {
    if (n >= ROW_BLOCK) dot_rows_n(rows, pad, ROW_BLOCK, x, out);
    else dot_rows_n(rows, pad, 1, x, out);
}

/* the mean port velocities over the step from the state now with no input: sum_i C_port_i (psi_p p + psi_q q) */
static void free_mean(const RomChannelModel *c, const RomModel *m, const ChannelCache *k, const ChannelState *cs,
                      double *out) {
    const size_t pad = c->pad;
    for (uint32_t j = 0; j < c->ports; j++) {
        const double *row = c->C_pad + (size_t)(3u * m->n_probes + j) * pad;
        double acc = 0.0;
        for (size_t i = 0; i < pad; i++) acc += row[i] * (k->map[PSIP][i] * cs->p[i] + k->map[PSIQ][i] * cs->q[i]);
        out[j] = acc;
    }
}

/* A x = b, n <= ROM_MAX_PORTS, Gaussian elimination with partial pivoting (A = I + Z M / area: M is symmetric
 * positive semi-definite, A is never singular); 0 when a pivot vanishes */
static int solve_small(uint32_t n, double *A, double *b) {
    for (uint32_t k = 0; k < n; k++) {
        uint32_t best = k;
        for (uint32_t i = k + 1; i < n; i++) {
            if (fabs(A[i * n + k]) > fabs(A[best * n + k])) best = i;
        }
        if (!(fabs(A[best * n + k]) > 0)) return 0;
        if (best != k) {
            for (uint32_t j = 0; j < n; j++) {
                const double t = A[k * n + j];
                A[k * n + j] = A[best * n + j];
                A[best * n + j] = t;
            }
            const double t = b[k];
            b[k] = b[best];
            b[best] = t;
        }
        for (uint32_t i = k + 1; i < n; i++) {
            const double f = A[i * n + k] / A[k * n + k];
            for (uint32_t j = k; j < n; j++) A[i * n + j] -= f * A[k * n + j];
            b[i] -= f * b[k];
        }
    }
    for (uint32_t k = n; k-- > 0;) {
        double acc = b[k];
        for (uint32_t j = k + 1; j < n; j++) acc -= A[k * n + j] * b[j];
        b[k] = acc / A[k * n + k];
    }
    return 1;
}

RomStatus rom_channel_step(RomState *s, double h, const double *v_own, const double *v_end, char *message,
                           size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs) return ROM_OK;
    const RomModel *m = s->model;
    const RomChannelModel *c = &m->channel;
    const uint32_t P = c->ports;
    if (v_end) {                           /* the kind's v_port now: its outputs' and the next step's start */
        for (uint32_t j = 0; j < P; j++) cs->v_kind[j] = v_end[j];
        cs->kind_valid = 1;
    }
    const ChannelCache *k = channel_maps(cs, m, h);
    double u[ROM_MAX_PORTS], du[ROM_MAX_PORTS];
    if (cs->impedance > 0.0) {             /* the wave form: F held, F = 2 abar - Z vbar, solved exactly */
        const double Z = cs->impedance;
        double A[ROM_MAX_PORTS * ROM_MAX_PORTS], F[ROM_MAX_PORTS], mean[ROM_MAX_PORTS], abar[ROM_MAX_PORTS];
        free_mean(c, m, k, cs, mean);
        for (uint32_t j = 0; j < P; j++) {
            /* the incident wave's mean over the step (held: a itself, bit for bit) */
            abar[j] = cs->wave_rate[j] != 0.0 ? cs->wave[j] + 0.5 * cs->wave_rate[j] * h : cs->wave[j];
            for (uint32_t l = 0; l < P; l++) A[j * P + l] = (j == l ? 1.0 : 0.0) + Z * k->M[j * P + l] / s->area;
            F[j] = 2.0 * abar[j] - Z * (mean[j] + (v_own ? v_own[j] : 0.0));
        }
        if (!solve_small(P, A, F) || !rom_all_finite(F, P)) {
            return rom_fail(message, message_size, "the wave form's port forces at t = %.9g s are not finite "
                            "(port_impedance = %g N s m^-1)", s->time, Z);
        }
        for (uint32_t j = 0; j < P; j++) {
            cs->applied[j] = F[j];
            cs->reflected[j] = abar[j] - F[j];
            u[j] = F[j] / s->area;
            du[j] = 0.0;
            if (cs->wave_rate[j] != 0.0) cs->wave[j] = cs->wave[j] + cs->wave_rate[j] * h;   /* a continues */
        }
    } else {
        for (uint32_t j = 0; j < P; j++) {
            u[j] = s->port_force[j] / s->area;
            du[j] = s->port_rate[j] * h / s->area;
        }
    }
    for (uint32_t j = 0; j < P; j++) {
        cs->tv[j] += fabs(u[j] - cs->u_prev[j]) + fabs(du[j]);
        cs->u_prev[j] = u[j] + du[j];
    }
    channel_drift(c, cs, h, u, du);
    step_planes(c, k, cs->p, cs->q, u, du);
    cs->steps += 1.0;
    cs->valid = 0;
    cs->norm_valid = 0;
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* outputs                                                                   */
/* ------------------------------------------------------------------------ */

/* rows over q: the e rows at the probes' particles (P .. 3P - 1); the others over p */
static int on_q(const RomModel *m, uint32_t r) {
    return r >= m->n_probes && r < 3u * m->n_probes;
}

/* the port inputs now [N m^-2] (the static correction's): the force form's F_j / area, the wave form's last held
 * force */
static void inputs_now(const RomState *s, const ChannelState *cs, double *u) {
    for (uint32_t j = 0; j < s->model->channel.ports; j++) {
        u[j] = (cs->impedance > 0.0 ? cs->applied[j] : s->port_force[j]) / s->area;
    }
}

static double density_shift(const RomState *s, ChannelState *cs, uint32_t j);

/* every row's plane part once per step, when first read: runs of rows over the same half of the state (p or q),
 * ROW_BLOCK at a time; and the probes' density shifts when no plane is truncated (then the rows are final) */
static void channel_outputs(const RomState *s, ChannelState *cs) {
    const RomModel *m = s->model;
    const RomChannelModel *c = &m->channel;
    for (uint32_t r = 0; r < c->rows;) {
        const int q_rows = on_q(m, r);
        uint32_t n = 1;
        while (n < ROW_BLOCK && r + n < c->rows && on_q(m, r + n) == q_rows) n++;
        dot_rows(c->C_pad + (size_t)r * c->pad, c->pad, n, q_rows ? cs->q : cs->p, cs->values + r);
        r += n;
    }
    cs->certs_valid = 0;                   /* computed when a bound asks for them */
    cs->valid = 1;
    if (!c->truncated) {
        for (uint32_t j = 0; j < m->n_probes; j++) cs->shift[j] = density_shift(s, cs, j);
    }
}

/* row r's value now (r < rows, cs->valid): its plane part, and the truncated planes' static correction */
CHANNEL_INLINE double row_value(const RomState *s, const ChannelState *cs, uint32_t r) {
    const RomChannelModel *c = &s->model->channel;
    double value = cs->values[r];
    if (c->truncated) {
        const uint32_t P = c->ports;
        const double *D = c->D + (size_t)r * (4 * P + 1);
        double u[ROM_MAX_PORTS];
        inputs_now(s, cs, u);
        for (uint32_t j = 0; j < P; j++) value += D[j] * u[j];
    }
    return value;
}

/* every row's certified bound, once per step (they change only with a step): the truncated planes' gains times
 * V(u_j), the decomposition's drift (its gains times the integrals, which n additions of positive terms leave within
 * (1 + eps)^n <= 1 + CHANNEL_ROUNDOFF_STEP n of their exact sums) and the round-off allowance on |w| */
static void channel_certs(const RomState *s, ChannelState *cs) {
    const RomChannelModel *c = &s->model->channel;
    const uint32_t P = c->ports;
    const double w_norm = channel_norm(c, cs);
    const double allowance = CHANNEL_ROUNDOFF + CHANNEL_ROUNDOFF_STEP * cs->steps;
    /* the drift is a Duhamel integral of e^{A (t - s)}, which grows by at most e^{growth t} (rom.h) */
    const double growth = rom_growth_factor(c->growth, s->elapsed);
    for (uint32_t r = 0; r < c->rows; r++) {
        const double *D = c->D + (size_t)r * (4 * P + 1);
        double gain = 0.0, drift = D[4 * P] * cs->w_int;
        for (uint32_t j = 0; j < P; j++) {
            gain += D[P + j] * cs->tv[j];
            drift += D[2 * P + j] * cs->u_int[j] + D[3 * P + j] * cs->tv_int[j];
        }
        cs->certs[r] = gain + drift * (1.0 + CHANNEL_ROUNDOFF_STEP * cs->steps) * growth +
                       allowance * c->row_norm[r] * w_norm;
    }
    cs->certs_valid = 1;
}

double rom_channel_row(const RomState *s, uint32_t r, double *cert) {
    if (cert) *cert = 0.0;
    if (!s) return NAN;
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs || r >= s->model->channel.rows) return 0.0;
    if (!cs->valid) channel_outputs(s, cs);
    if (cert) {
        if (!cs->certs_valid) channel_certs(s, cs);
        *cert = cs->certs[r];
    }
    return row_value(s, cs, r);
}

double rom_channel_port_velocity(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_ports) return NAN;
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs) return rom_port_velocity(s, j);
    const double v = cs->kind_valid ? cs->v_kind[j] : rom_channel_kind_velocity(s, j);
    if (!cs->valid) channel_outputs(s, cs);
    return v + row_value(s, cs, 3 * s->model->n_probes + j);
}

double rom_channel_row_rate(const RomState *s, uint32_t r) {
    const ChannelState *cs = (const ChannelState *)s->channel;
    if (!cs || r >= s->model->channel.rows) return 0.0;
    const RomModel *m = s->model;
    const RomChannelModel *c = &m->channel;
    const uint32_t P = c->ports;
    double u[ROM_MAX_PORTS];
    inputs_now(s, cs, u);
    const double *row = c->C + (size_t)r * c->planes;
    const int q_row = on_q(m, r);
    double rate = 0.0;
    for (uint32_t i = 0; i < c->planes; i++) {         /* (Lambda w + [beta u; 0])_p or _q */
        const double *L = c->lam + 4 * (size_t)i;
        double x;
        if (q_row) {
            x = L[2] * cs->p[i] + L[3] * cs->q[i];
        } else {
            x = L[0] * cs->p[i] + L[1] * cs->q[i];
            for (uint32_t j = 0; j < P; j++) x += c->beta[(size_t)i * P + j] * u[j];
        }
        rate += row[i] * x;
    }
    if (c->truncated && !(cs->impedance > 0.0)) {       /* the static correction follows the input's rate */
        const double *D = c->D + (size_t)r * (4 * P + 1);
        for (uint32_t j = 0; j < P; j++) rate += D[j] * s->port_rate[j] / s->area;
    }
    return rate;
}

double rom_channel_density_shift(const RomState *s, uint32_t j) {
    if (!s) return NAN;
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs || j >= s->model->n_probes) return 0.0;
    if (!cs->valid) channel_outputs(s, cs);
    return s->model->channel.truncated ? density_shift(s, cs, j) : cs->shift[j];
}

/* rom_channel_density_shift from the rows now (cs->valid) */
static double density_shift(const RomState *s, ChannelState *cs, uint32_t j) {
    const double *pr = s->model->channel.probe + 4 * (size_t)j;       /* pw0, pw1, rho0_0, rho0_1 */
    double shift = 0.0;
    for (uint32_t side = 0; side < 2; side++) {
        const double e = row_value(s, cs, s->model->n_probes + 2 * j + side);
        if (!(1.0 + e > 0)) return NAN;
        shift += pr[side] * pr[2 + side] * (1.0 / (1.0 + e) - 1.0);
    }
    return shift;
}

double rom_channel_energy(const RomState *s) {
    const ChannelState *cs = s ? (const ChannelState *)s->channel : NULL;
    if (!cs) return 0.0;
    double w2 = 0.0;
    for (uint32_t i = 0; i < s->model->channel.planes; i++) w2 += cs->p[i] * cs->p[i] + cs->q[i] * cs->q[i];
    return 0.5 * w2 * s->model->channel.dx * s->area;
}

/* ------------------------------------------------------------------------ */
/* the wave form's parameter and variables                                   */
/* ------------------------------------------------------------------------ */

RomStatus rom_set_port_impedance(RomState *s, double impedance, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs) {
        return rom_fail(message, message_size, "parameter port_impedance: this FMU has no port channel (the wave form "
                        "needs it)");
    }
    if (!(isfinite(impedance) && impedance >= 0)) {
        return rom_fail(message, message_size, "parameter port_impedance = %g N s m^-1 is out of range (allowed: a "
                        "finite number >= 0; 0: the force form)", impedance);
    }
    cs->impedance = impedance;
    return ROM_OK;
}

double rom_port_impedance(const RomState *s) {
    const ChannelState *cs = s ? (const ChannelState *)s->channel : NULL;
    return cs ? cs->impedance : NAN;
}

/* the channel of port j's wave (a_port_j), or NULL with the message naming the ports allowed */
static ChannelState *wave_port(RomState *s, uint32_t j, char *message, size_t message_size) {
    if (!s) {
        rom_fail(message, message_size, "no state");
        return NULL;
    }
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs || j >= s->model->n_ports) {
        rom_fail(message, message_size, "a_port_%u: no such port wave (allowed: 1 to %u with the port channel)",
                 j + 1, cs ? s->model->n_ports : 0u);
        return NULL;
    }
    return cs;
}

RomStatus rom_set_port_wave(RomState *s, uint32_t j, double wave, char *message, size_t message_size) {
    ChannelState *cs = wave_port(s, j, message, message_size);
    if (!cs || rom_check_port_input(s, "a_port", j, wave, "force wave", message, message_size) != ROM_OK) {
        return ROM_FAIL;
    }
    cs->wave[j] = wave;
    return ROM_OK;
}

RomStatus rom_set_port_wave_rate(RomState *s, uint32_t j, double rate, char *message, size_t message_size) {
    ChannelState *cs = wave_port(s, j, message, message_size);
    if (!cs || rom_check_port_input(s, "a_port", j, rate, NULL, message, message_size) != ROM_OK) return ROM_FAIL;
    cs->wave_rate[j] = rate;
    return ROM_OK;
}

double rom_port_wave_rate(const RomState *s, uint32_t j) {
    const ChannelState *cs = s ? (const ChannelState *)s->channel : NULL;
    return cs && j < s->model->n_ports ? cs->wave_rate[j] : NAN;
}

double rom_port_wave(const RomState *s, uint32_t j) {
    const ChannelState *cs = s ? (const ChannelState *)s->channel : NULL;
    return cs && j < s->model->n_ports ? cs->wave[j] : NAN;
}

double rom_port_reflected(const RomState *s, uint32_t j) {
    const ChannelState *cs = s ? (const ChannelState *)s->channel : NULL;
    return cs && j < s->model->n_ports ? cs->reflected[j] : NAN;
}

/* ------------------------------------------------------------------------ */
/* the serialized state: p[planes], q[planes], tv[P], u_prev[P], steps, Z, a[P], b[P], applied[P], da/dt[P],
 * then the drift's integrals u_int[P], tv_int[P], w_int                                                        */
/* ------------------------------------------------------------------------ */

size_t rom_channel_state_doubles(const RomModel *m) {
    const RomChannelModel *c = &m->channel;
    return c->planes ? 2 * (size_t)c->planes + 8 * (size_t)c->ports + 3 : 0;
}

RomStatus rom_channel_state_check(const RomModel *m, const unsigned char *cursor, char *message, size_t message_size) {
    const RomChannelModel *c = &m->channel;
    if (!c->planes) return ROM_OK;
    const unsigned char *at = cursor + 8 * (2 * (size_t)c->planes + 2 * (size_t)c->ports);
    const double steps = rom_get_f64(at), Z = rom_get_f64(at + 8);
    if (!(steps >= 0 && steps == floor(steps)) || !(isfinite(Z) && Z >= 0)) {
        return rom_fail(message, message_size, "serialized state: the port channel's step count %g or parameter "
                        "port_impedance = %g N s m^-1 is out of range (allowed: a whole number >= 0, a finite number "
                        ">= 0)", steps, Z);
    }
    for (uint32_t j = 0; j < c->ports; j++) {
        if (!(rom_get_f64(cursor + 8 * (2 * (size_t)c->planes + j)) >= 0)) {
            return rom_fail(message, message_size, "serialized state: the port channel's input variation of port %u "
                            "is negative", j + 1);
        }
    }
    const unsigned char *drift = cursor + 8 * (2 * (size_t)c->planes + 6 * (size_t)c->ports + 2);
    for (size_t i = 0; i < 2 * (size_t)c->ports + 1; i++) {
        const double x = rom_get_f64(drift + 8 * i);
        if (!(x >= 0 && isfinite(x))) {
            return rom_fail(message, message_size, "serialized state: the port channel's drift integral %zu is %g "
                            "(allowed: a finite number >= 0)", i + 1, x);
        }
    }
    return ROM_OK;
}

unsigned char *rom_channel_state_put(const RomState *s, unsigned char *cursor) {
    const ChannelState *cs = (const ChannelState *)s->channel;
    if (!cs) return cursor;
    const RomChannelModel *c = &s->model->channel;
    cursor = rom_put_f64s(cursor, cs->p, c->planes);
    cursor = rom_put_f64s(cursor, cs->q, c->planes);
    cursor = rom_put_f64s(cursor, cs->tv, c->ports);
    cursor = rom_put_f64s(cursor, cs->u_prev, c->ports);
    const double scalars[2] = {cs->steps, cs->impedance};
    cursor = rom_put_f64s(cursor, scalars, 2);
    cursor = rom_put_f64s(cursor, cs->wave, c->ports);
    cursor = rom_put_f64s(cursor, cs->reflected, c->ports);
    cursor = rom_put_f64s(cursor, cs->applied, c->ports);
    cursor = rom_put_f64s(cursor, cs->wave_rate, c->ports);
    cursor = rom_put_f64s(cursor, cs->u_int, c->ports);
    cursor = rom_put_f64s(cursor, cs->tv_int, c->ports);
    return rom_put_f64s(cursor, &cs->w_int, 1);
}

const unsigned char *rom_channel_state_get(RomState *s, const unsigned char *cursor) {
    ChannelState *cs = (ChannelState *)s->channel;
    if (!cs) return cursor;
    const RomChannelModel *c = &s->model->channel;
    cursor = rom_get_f64s(cursor, cs->p, c->planes);
    cursor = rom_get_f64s(cursor, cs->q, c->planes);
    cursor = rom_get_f64s(cursor, cs->tv, c->ports);
    cursor = rom_get_f64s(cursor, cs->u_prev, c->ports);
    double scalars[2];
    cursor = rom_get_f64s(cursor, scalars, 2);
    cs->steps = scalars[0];
    cs->impedance = scalars[1];
    cursor = rom_get_f64s(cursor, cs->wave, c->ports);
    cursor = rom_get_f64s(cursor, cs->reflected, c->ports);
    cursor = rom_get_f64s(cursor, cs->applied, c->ports);
    cursor = rom_get_f64s(cursor, cs->wave_rate, c->ports);
    cursor = rom_get_f64s(cursor, cs->u_int, c->ports);
    cursor = rom_get_f64s(cursor, cs->tv_int, c->ports);
    cursor = rom_get_f64s(cursor, &cs->w_int, 1);
    cs->valid = 0;
    cs->norm_valid = 0;
    cs->kind_valid = 0;                    /* the kind's state was read before the channel's */
    return cursor;
}
