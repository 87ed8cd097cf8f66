/*
 * The certified error bounds of every output (harness/rom/bounds.py builds the data; docs/science/error-bounds.md
 * derives them).  The truth is the full SPH of eqs. 2.10-2.11, exactly linear in J, in energy coordinates
 * x' = A x + B u from x(0) = s x0 (s = initial_state_scale).  With uniform damping A has invariant planes (one
 * per singular triplet of the coupling); the shadow keeps the lowest ones, w' = Lambda w + S^T B u, stepped here
 * exactly (each plane by the exponential of its augmented matrix, cached per step length), and per output row r
 *
 *   |row_r . x(t) - C_r . w(t)| <= |s| min(G_r(t_b), |c_r| |y0|)                    (the rest's free response)
 *                                 + min(sum_i sup|H_ri| V_i(u), |c_r| int |B_perp u|)  (the rest's forced response)
 *                                 + |c_r| |E| int |w|                                (round-off of the planes)
 *                                 + |c_r| (1e-9 + 1e-15 n) (|w| + |s| |x0|)         (floating point)
 *
 * V_i(u) = |u_i(0)| + the total variation of u_i.  An output's bound is |model - shadow| + that (the density
 * through rho = sum_m pw rho0 / (1 + e_m), harness/rom/bounds.py output_bounds).  O(k_s (m + 1)) per doStep,
 * no N.  The same arithmetic as harness/rom/bounds.py run_shadow (not bit for bit: a bound, compared within
 * tolerances).
 *
 * Without a uniform damping (section SHDENSE) the planes are not invariant: the shadow is one dense block (the
 * Galerkin model on them, SHLAM k_s x k_s), stepped by the exponential of its augmented matrix, O(k_s^2) per
 * doStep; G is |c_r| |y0| for all t, there is no sup|H|, mu comes from the file, and the residual term is
 * |c_r| int |E w| with E the true coupling residual (section SHEGRAM: E^T E), over each step h sqrt(Y^T Q Y)
 * (plus its round-off allowance), Q the exact quadratic form of the step (Van Loan's exponential, once per step
 * length, O(k_s^3)).
 *
 * A parametric model (sections SHPIECE, SHPARAM): the planes are affine in c and d about the scene's c_ref,
 * Lambda_i(c, d) = [[-d, (c / c_ref) sigma_i], [-sigma_i, 0]], assembled with the model's operators once c and d
 * are fixed (rom_bound_assemble); |c_r| and G of the e rows scale with sqrt(c_ref / c) (the energy norm at c),
 * |E| is the sum of its pieces' norms at (c, d), G is one all-time value and there is no sup|H| (the energy
 * alternative bounds the forced part).
 */
#include "rom_internal.h"
#include "rom_numerics.h"

#include <stdio.h>
#include <stdlib.h>

#define BOUND_ROUNDOFF 1e-9            /* harness/rom/bounds.py ROUNDOFF */
#define BOUND_ROUNDOFF_STEP 1e-15      /* ... ROUNDOFF_STEP */
#define BOUND_CACHE 2                  /* step lengths whose plane maps are kept */
#define BOUND_MAX_INPUTS (1u + ROM_MAX_PORTS)
#define BOUND_QUAD_ROUNDOFF 1e-14      /* harness/rom/bounds.py QUAD_ROUNDOFF */

typedef struct {
    double h;                  /* 0: empty */
    int64_t used;
    double *Phi;               /* [planes][4], or [k_s][k_s] for one dense block */
    double *G0, *G1;           /* [order][inputs] */
    double *Q;                 /* dense: [n][n], n = order + 2 inputs: int_0^h |E w|^2 = h Y^T Q Y, Y = (w, u, du) */
    double q_allow;            /* dense: the form's round-off per |Y|^2, 1e-14 (trace(Q) + |F12|_1 |F22|_1) */
} BoundCache;

typedef struct {
    double *w, *w_new;         /* [order] the shadow's state, scratch */
    double tv[BOUND_MAX_INPUTS];       /* |u(0)| + total variation of each input so far */
    double u_prev[BOUND_MAX_INPUTS];   /* the input at the end of the last step */
    double p_int;              /* int |B_perp u| dt so far (Cauchy-Schwarz per step) */
    double w_int;              /* int |w| dt so far (a bound); dense: int |E w| dt */
    double steps;              /* steps taken (the round-off allowance) */
    double started;            /* 1 once w holds s w0 and its steps (the first doStep), 0 before */
    BoundCache cache[BOUND_CACHE];
    int64_t clock;
    double *work;              /* planes: [4][n][n], n = 2 + 2 inputs (the exponential's matrices); dense:
                                * n = k_s + 2 inputs, M [n][n] then [4][2n][2n] (the residual's Van Loan) */
    void *storage_;
} BoundState;

static const char *const TAGS[] = {"SHSCAL", "SHLAM", "SHB", "SHC", "SHW0", "SHGRAM", "SHROW", "SHPROBE"};
#define N_TAGS (sizeof TAGS / sizeof TAGS[0])

RomStatus rom_bound_check_section(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    (void)m;
    if (!s || s->rows == 0 || s->cols == 0) return rom_fail(message, message_size, "resources: an empty section");
    return ROM_OK;      /* the sizes against each other: rom_bound_prepare, once every section is read */
}

static RomStatus shape(const RomSection *s, uint32_t rows, uint32_t cols, char *message, size_t message_size) {
    if (s->rows != rows || s->cols != cols) {
        return rom_fail(message, message_size, "resources: section %s is %u x %u, expected %u x %u (the error "
                        "bounds' shadow)", s->tag, s->rows, s->cols, rows, cols);
    }
    return ROM_OK;
}

static int whole(double x, double lo, double hi) {
    return x >= lo && x <= hi && x == floor(x);
}

/* the largest eigenvalue of a plane's symmetric part, over the planes (0 at least) */
static double plane_growth(const double *lam, uint32_t planes) {
    double mu = 0.0;
    for (uint32_t p = 0; p < planes; p++) {
        const double *L = lam + 4 * (size_t)p;
        const double a = L[0], c = 0.5 * (L[1] + L[2]), d = L[3];
        const double top = 0.5 * (a + d) + sqrt(0.25 * (a - d) * (a - d) + c * c);
        if (top > mu) mu = top;
    }
    return mu;
}

/* a parametric shadow at (c, d): Lambda_i = SHLAM_i + c piece_i[0:4] + d piece_i[4:8] (harness/rom/bounds.py
 * Shadow.blocks, the same order), mu, |E(c, d)| = sum_p coef_p (E_p,v + sqrt(c / c_ref) E_p,e) (coef 1, c, d:
 * Shadow.residual_norm) and the e rows' scale sqrt(c_ref / c) (Shadow.dual_norms) */
static RomStatus assemble_planes(RomBoundModel *b, const double *lam0, double c, double d, char *message,
                                 size_t message_size) {
    if (!b->piece || !b->storage_) return rom_fail(message, message_size, "the error bounds' shadow is not parametric");
    if (!(isfinite(c) && c > 0) || !(isfinite(d) && d >= 0)) {
        return rom_fail(message, message_size, "the error bounds' shadow at c = %g, d = %g (allowed: c > 0, d >= 0, "
                        "finite)", c, d);
    }
    for (uint32_t p = 0; p < b->planes; p++) {
        for (size_t i = 0; i < 4; i++) {
            b->storage_[4 * (size_t)p + i] = lam0[4 * (size_t)p + i] + c * b->piece[8 * (size_t)p + i] +
                                             d * b->piece[8 * (size_t)p + 4 + i];
        }
    }
    const double coef[3] = {1.0, c, d}, ratio = sqrt(c / b->c_ref);
    double e_norm = 0.0;
    for (size_t p = 0; p < 3; p++) e_norm += coef[p] * (b->e_piece[2 * p] + ratio * b->e_piece[2 * p + 1]);
    b->lam = b->storage_;
    b->mu = plane_growth(b->storage_, b->planes);
    b->e_norm = e_norm;
    b->e_scale = sqrt(b->c_ref / c);
    return ROM_OK;
}

/* sections SHPIECE and SHPARAM (a parametric shadow: both, with PARAMS, or neither); assembled at PARAMS' start */
static RomStatus prepare_pieces(RomModel *m, char *message, size_t message_size) {
    RomBoundModel *b = &m->bound;
    const RomSection *piece = rom_section(m, "SHPIECE"), *parm = rom_section(m, "SHPARAM");
    const RomSection *params = rom_section(m, "PARAMS");
    b->e_scale = 1.0;
    if (!piece && !parm) return ROM_OK;
    if (!piece || !parm || !params || !b->order || b->dense) {
        return rom_fail(message, message_size, "resources: the error bounds' sections SHPIECE and SHPARAM come "
                        "together, with the sections SH* and PARAMS (a parametric model), without SHDENSE");
    }
    if (shape(piece, b->planes, 8, message, message_size) != ROM_OK ||
        shape(parm, 1, ROM_SHPARAM_COLUMNS, message, message_size) != ROM_OK) return ROM_FAIL;
    const double *v = parm->data;
    if (!(v[ROM_SHPARAM_C_REF] > 0)) {
        return rom_fail(message, message_size, "resources: section SHPARAM's c_ref = %g (allowed: > 0)",
                        v[ROM_SHPARAM_C_REF]);
    }
    for (size_t i = 0; i < 6; i++) {                  /* the six norms after c_ref */
        if (!(v[ROM_SHPARAM_E_CONST_V + i] >= 0)) {
            return rom_fail(message, message_size, "resources: section SHPARAM's residual norm %g (allowed: >= 0)",
                            v[ROM_SHPARAM_E_CONST_V + i]);
        }
    }
    b->storage_ = (double *)calloc(4 * (size_t)b->planes, sizeof(double));
    if (!b->storage_) return rom_fail(message, message_size, "resources: out of memory (the error bounds' planes)");
    b->piece = piece->data;
    b->c_ref = v[ROM_SHPARAM_C_REF];
    for (size_t i = 0; i < 6; i++) b->e_piece[i] = v[ROM_SHPARAM_E_CONST_V + i];
    return assemble_planes(b, rom_section(m, "SHLAM")->data, params->data[1], params->data[4 + 1], message,
                           message_size);
}

RomStatus rom_bound_assemble(RomModel *m, RomState *s, char *message, size_t message_size) {
    if (!m || !s || s->model != m) return rom_fail(message, message_size, "assemble: no model or a foreign state");
    RomBoundModel *b = &m->bound;
    if (!b->piece) return ROM_OK;
    if (assemble_planes(b, rom_section(m, "SHLAM")->data, s->c, s->d, message, message_size) != ROM_OK) {
        return ROM_FAIL;
    }
    BoundState *bs = (BoundState *)s->bound;
    if (bs) {
        for (int c = 0; c < BOUND_CACHE; c++) bs->cache[c].h = 0.0;     /* the plane maps of the old planes */
    }
    return ROM_OK;
}

RomStatus rom_bound_prepare(RomModel *m, char *message, size_t message_size) {
    memset(&m->bound, 0, sizeof m->bound);
    const RomSection *sec[N_TAGS];
    size_t found = 0;
    for (size_t i = 0; i < N_TAGS; i++) {
        sec[i] = rom_section(m, TAGS[i]);
        found += sec[i] != NULL;
    }
    if (found == 0) {
        if (rom_section(m, "SHPIECE") || rom_section(m, "SHPARAM") || rom_section(m, "SHDENSE") ||
            rom_section(m, "SHEGRAM")) {
            return rom_fail(message, message_size, "resources: the error bounds' sections SHPIECE, SHPARAM, "
                            "SHDENSE or SHEGRAM without the sections SH*");
        }
        return ROM_OK;
    }
    if (found != N_TAGS) {
        return rom_fail(message, message_size, "resources: the error bounds' sections SHSCAL, SHLAM, SHB, SHC, SHW0, "
                        "SHGRAM, SHROW, SHPROBE come together (%zu of %zu present)", found, (size_t)N_TAGS);
    }
    const RomSection *scal = sec[0], *dense = rom_section(m, "SHDENSE");
    if (shape(scal, 1, ROM_SHSCAL_COLUMNS, message, message_size) != ROM_OK) return ROM_FAIL;
    const double *v = scal->data;
    /* inputs: f and the port forces the kind takes (none with the port channel, which is exact for them and adds
     * its own part and bound to each row: shadow_row) */
    const uint32_t inputs = 1u + rom_port_inputs(m), rows = 3u * m->n_probes + m->n_ports;
    if (!whole(v[ROM_SHSCAL_PLANES], 1, ROM_MAX_MODES) || v[ROM_SHSCAL_ORDER] != 2.0 * v[ROM_SHSCAL_PLANES] ||
        v[ROM_SHSCAL_INPUTS] != (double)inputs || v[ROM_SHSCAL_ROWS] != (double)rows ||
        !whole(v[ROM_SHSCAL_N_TAB], 1, 1e6) || !(v[ROM_SHSCAL_DT_TAB] > 0) || v[ROM_SHSCAL_Y0_NORM] < 0 ||
        v[ROM_SHSCAL_X0_NORM] < 0 || v[ROM_SHSCAL_E_NORM] < 0 || v[ROM_SHSCAL_B_NORM] < 0 ||
        v[ROM_SHSCAL_TOLERANCE] < 0) {
        return rom_fail(message, message_size, "resources: section SHSCAL (the error bounds' sizes) does not fit the "
                        "model (%u inputs, %u output rows expected; planes 1 to %u)", inputs, rows, ROM_MAX_MODES);
    }
    RomBoundModel *b = &m->bound;
    const uint32_t planes = (uint32_t)v[ROM_SHSCAL_PLANES], order = 2u * planes;
    const uint32_t n_tab = (uint32_t)v[ROM_SHSCAL_N_TAB];
    const RomSection *egram = rom_section(m, "SHEGRAM");
    if ((dense == NULL) != (egram == NULL)) {
        return rom_fail(message, message_size, "resources: the error bounds' sections SHDENSE and SHEGRAM come "
                        "together (one dense block)");
    }
    if (dense && (shape(dense, 1, 1, message, message_size) != ROM_OK || !(dense->data[0] >= 0))) {
        return rom_fail(message, message_size, "resources: section SHDENSE (the error bounds' dense block's growth "
                        "rate mu = %g s^-1) must be one number >= 0", dense->rows == 1 && dense->cols == 1 ?
                        dense->data[0] : NAN);
    }
    if (egram && shape(egram, order, order, message, message_size) != ROM_OK) return ROM_FAIL;
    if (shape(sec[1], dense ? order : planes, dense ? order : 4, message, message_size) != ROM_OK ||
        shape(sec[2], order, inputs, message, message_size) != ROM_OK ||
        shape(sec[3], rows, order, message, message_size) != ROM_OK ||
        shape(sec[4], 1, order, message, message_size) != ROM_OK ||
        shape(sec[5], inputs, inputs, message, message_size) != ROM_OK ||
        shape(sec[6], rows, 1 + inputs + n_tab, message, message_size) != ROM_OK ||
        shape(sec[7], m->n_probes, 4, message, message_size) != ROM_OK) return ROM_FAIL;
    /* the largest eigenvalue of a block's symmetric part: the planes' here, the dense block's from the file */
    const double mu = dense ? dense->data[0] : plane_growth(sec[1]->data, planes);
    b->order = order;
    b->planes = planes;
    b->dense = dense != NULL;
    b->egram = egram ? egram->data : NULL;
    b->inputs = inputs;
    b->rows = rows;
    b->n_tab = n_tab;
    b->dt_tab = v[ROM_SHSCAL_DT_TAB];
    b->y0_norm = v[ROM_SHSCAL_Y0_NORM];
    b->x0_norm = v[ROM_SHSCAL_X0_NORM];
    b->e_norm = v[ROM_SHSCAL_E_NORM];
    b->b_norm = v[ROM_SHSCAL_B_NORM];
    b->tolerance = v[ROM_SHSCAL_TOLERANCE];
    b->mu = mu;
    b->lam = sec[1]->data;
    b->B = sec[2]->data;
    b->C = sec[3]->data;
    b->w0 = sec[4]->data;
    b->gram = sec[5]->data;
    b->row = sec[6]->data;
    b->probe = sec[7]->data;
    return prepare_pieces(m, message, message_size);
}

int rom_has_bounds(const RomModel *m) {
    return m && m->bound.order > 0;
}

RomStatus rom_bound_state_new(RomState *s) {
    const RomBoundModel *b = &s->model->bound;
    s->bound = NULL;
    if (!b->order) return ROM_OK;
    BoundState *bs = (BoundState *)calloc(1, sizeof(BoundState));
    if (!bs) return ROM_FAIL;
    const size_t k = b->order, m = b->inputs, n = (b->dense ? k : 2) + 2 * m;   /* the augmented matrix's size */
    const size_t nw = b->dense ? 2 * n : n;                                      /* the largest exponential */
    size_t counts[3 + 4 * BOUND_CACHE] = {k, k, 4 * nw * nw + (b->dense ? n * n : 0)};   /* dense: M, then 4 (2n)^2 */
    double **ptrs[3 + 4 * BOUND_CACHE] = {&bs->w, &bs->w_new, &bs->work};
    for (int c = 0; c < BOUND_CACHE; c++) {
        counts[3 + 4 * c] = b->dense ? k * k : 4 * (size_t)b->planes;
        counts[4 + 4 * c] = k * m;
        counts[5 + 4 * c] = k * m;
        counts[6 + 4 * c] = b->dense ? n * n : 1;
        ptrs[3 + 4 * c] = &bs->cache[c].Phi;
        ptrs[4 + 4 * c] = &bs->cache[c].G0;
        ptrs[5 + 4 * c] = &bs->cache[c].G1;
        ptrs[6 + 4 * c] = &bs->cache[c].Q;
    }
    bs->storage_ = rom_alloc_arrays(counts, ptrs, 3 + 4 * BOUND_CACHE);
    if (!bs->storage_) {
        free(bs);
        return ROM_FAIL;
    }
    s->bound = bs;
    return ROM_OK;
}

void rom_bound_state_free(RomState *s) {
    BoundState *bs = (BoundState *)s->bound;
    if (!bs) return;
    free(bs->storage_);
    free(bs);
    s->bound = NULL;
}

void rom_bound_reset(RomState *s) {
    s->error_tolerance = s->model->bound.tolerance;
    BoundState *bs = (BoundState *)s->bound;
    if (!bs) return;
    const size_t k = s->model->bound.order;
    memset(bs->w, 0, k * sizeof(double));
    for (uint32_t i = 0; i < BOUND_MAX_INPUTS; i++) bs->tv[i] = bs->u_prev[i] = 0.0;
    bs->p_int = bs->w_int = bs->steps = bs->started = 0.0;
    for (int c = 0; c < BOUND_CACHE; c++) bs->cache[c].h = 0.0;      /* the maps stay valid; kept empty anyway */
}

/* the residual's quadratic form of a step (harness/rom/bounds.py residual_gram): with M the block's augmented
 * matrix (n = k_s + 2 m square, in the work buffer's first n x n), Q = int_0^1 e^{M^T s} diag(E^T E, 0, 0)
 * e^{M s} ds = F22^T F12 of the exponential F of [[-M^T, diag(E^T E, 0, 0)], [0, M]] (Van Loan), symmetrised */
static void residual_gram(BoundState *bs, const RomBoundModel *b, const double *M, BoundCache *slot) {
    const size_t k = b->order, m = b->inputs, n = k + 2 * m, nn = 2 * n;
    double *V = bs->work + n * n, *F = V + nn * nn, *X = F + nn * nn, *T = X + nn * nn;   /* after M */
    memset(V, 0, nn * nn * sizeof(double));
    for (size_t i = 0; i < n; i++) {
        for (size_t j = 0; j < n; j++) {
            V[i * nn + j] = -M[j * n + i];
            V[(n + i) * nn + n + j] = M[i * n + j];
        }
    }
    for (size_t i = 0; i < k; i++) {
        for (size_t j = 0; j < k; j++) V[i * nn + n + j] = b->egram[i * k + j];
    }
    double trace = 0.0;
    if (!rom_expm_taylor(nn, V, F, X, T)) {
        for (size_t i = 0; i < n * n; i++) slot->Q[i] = NAN;            /* the bounds become NaN: visible */
        slot->q_allow = NAN;
        return;
    }
    double f12 = 0.0, f22 = 0.0;                                          /* 1-norms: the largest column sums */
    for (size_t j = 0; j < n; j++) {
        double a12 = 0.0, a22 = 0.0;
        for (size_t i = 0; i < n; i++) {
            a12 += fabs(F[i * nn + n + j]);
            a22 += fabs(F[(n + i) * nn + n + j]);
        }
        f12 = fmax(f12, a12);
        f22 = fmax(f22, a22);
    }
    for (size_t i = 0; i < n; i++) {                                      /* (F22^T F12)[i][j] */
        for (size_t j = 0; j < n; j++) {
            double acc = 0.0;
            for (size_t l = 0; l < n; l++) acc += F[(n + l) * nn + n + i] * F[l * nn + n + j];
            slot->Q[i * n + j] = acc;
        }
    }
    for (size_t i = 0; i < n; i++) {
        for (size_t j = 0; j < i; j++) {
            const double q = 0.5 * (slot->Q[i * n + j] + slot->Q[j * n + i]);
            slot->Q[i * n + j] = slot->Q[j * n + i] = q;
        }
        trace += slot->Q[i * n + i];
    }
    slot->q_allow = BOUND_QUAD_ROUNDOFF * (trace + f12 * f22);
}

/* the dense block's maps of a step h into slot: the exponential of [[L h, B h, 0], [0, 0, I], [0, 0, 0]]
 * (k_s + 2 m square, O(k_s^3) once per step length; harness/rom/bounds.py block_maps) */
static const BoundCache *dense_maps(BoundState *bs, const RomBoundModel *b, double h, BoundCache *slot) {
    const size_t k = b->order, m = b->inputs, n = k + 2 * m;
    double *M = bs->work, *E = M + n * n, *X = E + n * n, *T = X + n * n;
    memset(M, 0, n * n * sizeof(double));
    for (size_t i = 0; i < k; i++) {
        for (size_t j = 0; j < k; j++) M[i * n + j] = b->lam[i * k + j] * h;
        for (size_t c = 0; c < m; c++) M[i * n + k + c] = b->B[i * m + c] * h;
    }
    for (size_t c = 0; c < m; c++) M[(k + c) * n + k + m + c] = 1.0;
    if (!rom_expm_taylor(n, M, E, X, T)) {
        for (size_t i = 0; i < k * k; i++) slot->Phi[i] = NAN;          /* the bounds become NaN: visible */
    } else {
        for (size_t i = 0; i < k; i++) {
            for (size_t j = 0; j < k; j++) slot->Phi[i * k + j] = E[i * n + j];
            for (size_t c = 0; c < m; c++) {
                slot->G0[i * m + c] = E[i * n + k + c];
                slot->G1[i * m + c] = E[i * n + k + m + c];
            }
        }
    }
    residual_gram(bs, b, M, slot);
    slot->h = h;
    slot->used = bs->clock;
    return slot;
}

/* the plane maps of a step h (from time t): per plane the exponential of [[L h, B_p h, 0], [0, 0, I], [0, 0, 0]] */
static const BoundCache *plane_maps(BoundState *bs, const RomBoundModel *b, double h, double t) {
    bs->clock++;
    for (int c = 0; c < BOUND_CACHE; c++) {
        if (rom_same_step(h, bs->cache[c].h, t)) {     /* (an importer's jitter of a few ulps: the same step) */
            bs->cache[c].used = bs->clock;
            return &bs->cache[c];
        }
    }
    BoundCache *slot = &bs->cache[0];
    for (int c = 1; c < BOUND_CACHE; c++) {
        if (bs->cache[c].used < slot->used) slot = &bs->cache[c];
    }
    if (b->dense) return dense_maps(bs, b, h, slot);
    const size_t m = b->inputs, n = 2 + 2 * m;
    double *M = bs->work, *E = M + n * n, *X = E + n * n, *T = X + n * n;
    for (uint32_t p = 0; p < b->planes; p++) {
        memset(M, 0, n * n * sizeof(double));
        for (size_t i = 0; i < 2; i++) {
            for (size_t j = 0; j < 2; j++) M[i * n + j] = b->lam[4 * p + 2 * i + j] * h;
            for (size_t c = 0; c < m; c++) M[i * n + 2 + c] = b->B[(2 * p + i) * m + c] * h;
        }
        for (size_t c = 0; c < m; c++) M[(2 + c) * n + 2 + m + c] = 1.0;
        if (!rom_expm_taylor(n, M, E, X, T)) {
            for (size_t i = 0; i < 4; i++) slot->Phi[4 * p + i] = NAN;      /* the bounds become NaN: visible */
            continue;
        }
        for (size_t i = 0; i < 2; i++) {
            for (size_t j = 0; j < 2; j++) slot->Phi[4 * p + 2 * i + j] = E[i * n + j];
            for (size_t c = 0; c < m; c++) {
                slot->G0[(2 * p + i) * m + c] = E[i * n + 2 + c];
                slot->G1[(2 * p + i) * m + c] = E[i * n + 2 + m + c];
            }
        }
    }
    slot->h = h;
    slot->used = bs->clock;
    return slot;
}

static double norm2(const double *x, size_t n) {
    double acc = 0.0;
    for (size_t i = 0; i < n; i++) acc += x[i] * x[i];
    return sqrt(acc);
}

/* the inputs over the step: u (its value at the step's start) and du (its change over the step) */
static void step_inputs(const RomState *s, double h, double *u, double *du) {
    u[0] = s->f;
    du[0] = s->f_rate * h;
    for (uint32_t j = 0; j < rom_port_inputs(s->model); j++) {
        u[1 + j] = s->port_force[j] / s->area;
        du[1 + j] = s->port_rate[j] * h / s->area;
    }
}

void rom_bound_step(RomState *s, double h) {
    BoundState *bs = (BoundState *)s->bound;
    if (!bs) return;
    const RomBoundModel *b = &s->model->bound;
    const size_t k = b->order, m = b->inputs;
    if (bs->started == 0.0) {
        for (size_t i = 0; i < k; i++) bs->w[i] = s->initial_state_scale * b->w0[i];
        bs->started = 1.0;
    }
    double u[BOUND_MAX_INPUTS], du[BOUND_MAX_INPUTS], end[BOUND_MAX_INPUTS];
    step_inputs(s, h, u, du);
    double q = 0.0;                     /* int_0^h |B_perp u|^2 / h for u linear over the step */
    for (size_t i = 0; i < m; i++) {
        bs->tv[i] += fabs(u[i] - bs->u_prev[i]) + fabs(du[i]);
        end[i] = u[i] + du[i];
        bs->u_prev[i] = end[i];
        for (size_t j = 0; j < m; j++) {
            q += b->gram[i * m + j] * (u[i] * u[j] + u[i] * du[j] + du[i] * du[j] / 3.0);
        }
    }
    bs->p_int += sqrt(fmax(h * h * q, 0.0));
    const BoundCache *c = plane_maps(bs, b, h, s->time);
    if (b->dense) {                     /* int |E w| <= h sqrt(Y^T Q Y) over the step, Y = (w, u, du) */
        const size_t n = k + 2 * m;
        double quad = 0.0, y2 = 0.0;
        for (size_t i = 0; i < n; i++) {
            const double yi = i < k ? bs->w[i] : i < k + m ? u[i - k] : du[i - k - m];
            double acc = 0.0;
            for (size_t j = 0; j < n; j++) {
                const double yj = j < k ? bs->w[j] : j < k + m ? u[j - k] : du[j - k - m];
                acc += c->Q[i * n + j] * yj;
            }
            quad += yi * acc;
            y2 += yi * yi;
        }
        bs->w_int += h * sqrt(fmax(quad + c->q_allow * y2, 0.0));
    } else {                            /* int |w| (a bound), for |c_r| |E| int |w| */
        const double u_big = fmax(norm2(u, m), norm2(end, m));
        bs->w_int += h * exp(b->mu * h) * (norm2(bs->w, k) + h * b->b_norm * u_big);
    }
    if (b->dense) {                     /* one dense block: O(k_s^2) */
        for (size_t i = 0; i < k; i++) {
            double acc = 0.0;
            const double *Phi = c->Phi + i * k;
            for (size_t j = 0; j < k; j++) acc += Phi[j] * bs->w[j];
            for (size_t j = 0; j < m; j++) acc += c->G0[i * m + j] * u[j] + c->G1[i * m + j] * du[j];
            bs->w_new[i] = acc;
        }
    }
    for (uint32_t p = 0; p < (b->dense ? 0u : b->planes); p++) {
        const double *Phi = c->Phi + 4 * (size_t)p;
        const double w0 = bs->w[2 * p], w1 = bs->w[2 * p + 1];
        for (size_t i = 0; i < 2; i++) {
            double acc = Phi[2 * i] * w0 + Phi[2 * i + 1] * w1;
            const size_t r = (2 * p + i) * m;
            for (size_t j = 0; j < m; j++) acc += c->G0[r + j] * u[j] + c->G1[r + j] * du[j];
            bs->w_new[2 * p + i] = acc;
        }
    }
    memcpy(bs->w, bs->w_new, k * sizeof(double));
    bs->steps += 1.0;
}

/* the shadow's state now (s w0 before the first step) into out[order] */
static const double *shadow_state(const RomState *s, double *scratch) {
    const BoundState *bs = (const BoundState *)s->bound;
    if (bs->started != 0.0) return bs->w;
    const RomBoundModel *b = &s->model->bound;
    for (size_t i = 0; i < b->order; i++) scratch[i] = s->initial_state_scale * b->w0[i];
    return scratch;
}

/* (the shadow's row r, its certified error) at the state's time */
static void shadow_row(const RomState *s, uint32_t r, double *value, double *cert) {
    const RomBoundModel *b = &s->model->bound;
    const BoundState *bs = (const BoundState *)s->bound;
    double scratch[2 * ROM_MAX_MODES];
    const double *w = shadow_state(s, scratch);
    const size_t k = b->order, m = b->inputs;
    const double *Cr = b->C + (size_t)r * k;
    double y = 0.0;
    for (size_t i = 0; i < k; i++) y += Cr[i] * w[i];
    const double *row = b->row + (size_t)r * (1 + m + b->n_tab);
    const uint32_t P = s->model->n_probes;
    const double row_scale = r >= P && r < 3 * P ? b->e_scale : 1.0;     /* e rows of a parametric shadow */
    const double cn = row[0] * row_scale, scale = fabs(s->initial_state_scale);
    const double tau = s->time - s->t0;
    double at = tau > 0 ? floor(tau / b->dt_tab) : 0.0;       /* t_b <= tau: G(t_b) holds for every t >= t_b */
    if (!(at < (double)b->n_tab - 1)) at = (double)b->n_tab - 1;
    const double g_init = scale * fmin(row[1 + m + (size_t)at] * row_scale, cn * b->y0_norm);
    double g_hold = 0.0;
    for (size_t i = 0; i < m; i++) {
        if (bs->tv[i] > 0) g_hold += row[1 + i] < 0 ? INFINITY : row[1 + i] * bs->tv[i];
    }
    const double g_input = fmin(g_hold, cn * bs->p_int);
    const double allow = cn * (BOUND_ROUNDOFF + BOUND_ROUNDOFF_STEP * bs->steps) * (norm2(w, k) + scale * b->x0_norm);
    const double residual = b->dense ? cn * bs->w_int : cn * b->e_norm * bs->w_int;   /* dense: int |E w| */
    double channel_cert;                    /* the port channel's part of the row and its own bound (rom_port.c) */
    *value = y + rom_channel_row(s, r, &channel_cert);
    *cert = g_init + g_input + residual + allow + channel_cert;
}

double rom_v_probe_error_bound(const RomState *s, uint32_t j) {
    if (!s || !s->bound || j >= s->model->n_probes) return NAN;
    double y, cert;
    shadow_row(s, j, &y, &cert);
    /* the model's output as rom.c rom_v_probe gives it: the kind's and the port channel's */
    return fabs(s->model->ops->v_probe(s, j) + rom_channel_row(s, j, NULL) - y) + cert;
}

double rom_rho_probe_error_bound(const RomState *s, uint32_t j) {
    if (!s || !s->bound || j >= s->model->n_probes) return NAN;
    const uint32_t P = s->model->n_probes;
    const double *pr = s->model->bound.probe + 4 * (size_t)j;     /* pw0, pw1, rho0_0, rho0_1 */
    double rho_s = 0.0, part = 0.0;
    for (uint32_t side = 0; side < 2; side++) {
        double e, beta;
        shadow_row(s, P + 2 * j + side, &e, &beta);
        const double J = 1.0 + e, low = J - beta;
        if (!(low > 0)) return INFINITY;        /* the certified interval of J reaches 0: no density bound */
        rho_s += pr[side] * pr[2 + side] / J;
        part += pr[side] * pr[2 + side] * beta / (J * low);
    }
    const double rho = s->model->ops->rho_probe(s, j) +       /* as rom.c rom_rho_probe: with the channel's part */
                       (s->model->ops->density_with_channel ? 0.0 : rom_channel_density_shift(s, j));
    return fabs(rho - rho_s) + part + 1e-15 * (pr[0] * pr[2] + pr[1] * pr[3]);
}

double rom_v_port_error_bound(const RomState *s, uint32_t j) {
    if (!s || !s->bound || j >= s->model->n_ports) return NAN;
    double y, cert;
    shadow_row(s, 3 * s->model->n_probes + j, &y, &cert);
    return fabs(rom_port_velocity(s, j) + rom_channel_row(s, 3 * s->model->n_probes + j, NULL) - y) + cert;
}

RomStatus rom_set_error_tolerance(RomState *s, double tolerance, char *message, size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (!(isfinite(tolerance) && tolerance >= 0)) {
        return rom_fail(message, message_size, "error_tolerance = %g is out of range (allowed: a finite number >= 0 "
                        "[m s^-1]; 0: no warning)", tolerance);
    }
    s->error_tolerance = tolerance;
    return ROM_OK;
}

int rom_bound_exceeded(const RomState *s, char *message, size_t message_size) {
    if (!s || !s->bound || !(s->error_tolerance > 0)) return 0;
    for (uint32_t port = 0; port < 2; port++) {
        const uint32_t n = port ? s->model->n_ports : s->model->n_probes;
        for (uint32_t j = 0; j < n; j++) {
            const double bound = port ? rom_v_port_error_bound(s, j) : rom_v_probe_error_bound(s, j);
            if (!(bound <= s->error_tolerance)) {
                if (message && message_size) {
                    snprintf(message, message_size, "%s_%u's certified error bound %.3g m s^-1 exceeds "
                             "error_tolerance = %.3g m s^-1 at t = %.9g s", port ? "v_port" : "v_probe", j + 1, bound,
                             s->error_tolerance, s->time);
                }
                return 1;
            }
        }
    }
    return 0;
}

size_t rom_bound_state_doubles(const RomModel *m) {
    const RomBoundModel *b = &m->bound;
    return b->order ? b->order + 2 * (size_t)b->inputs + 4 : 0;
}

unsigned char *rom_bound_state_put(const RomState *s, unsigned char *cursor) {
    const BoundState *bs = (const BoundState *)s->bound;
    if (!bs) return cursor;
    const RomBoundModel *b = &s->model->bound;
    cursor = rom_put_f64s(cursor, bs->w, b->order);
    cursor = rom_put_f64s(cursor, bs->tv, b->inputs);
    cursor = rom_put_f64s(cursor, bs->u_prev, b->inputs);
    const double scalars[4] = {bs->p_int, bs->w_int, bs->steps, bs->started};
    return rom_put_f64s(cursor, scalars, 4);
}

const unsigned char *rom_bound_state_get(RomState *s, const unsigned char *cursor) {
    BoundState *bs = (BoundState *)s->bound;
    if (!bs) return cursor;
    const RomBoundModel *b = &s->model->bound;
    cursor = rom_get_f64s(cursor, bs->w, b->order);
    cursor = rom_get_f64s(cursor, bs->tv, b->inputs);
    cursor = rom_get_f64s(cursor, bs->u_prev, b->inputs);
    double scalars[4];
    cursor = rom_get_f64s(cursor, scalars, 4);
    bs->p_int = scalars[0];
    bs->w_int = scalars[1];
    bs->steps = scalars[2];
    bs->started = scalars[3] != 0.0 ? 1.0 : 0.0;
    return cursor;
}
