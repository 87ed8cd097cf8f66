/*
 * The certified error bounds of every output (harness/rom/bounds.py builds the data; docs/science/error-bounds.md
 * derives them).  The truth is the full SPH of eqs. 2.10-2.11, exactly linear in J, in energy coordinates
 * x' = A x + B u from x(0) = s x0 (s = initial_state_scale), integrated exactly in time.  A is block diagonal in
 * invariant planes; the shadow keeps the lowest ones, w' = Lambda w + B_s u, stepped here exactly (each plane by the
 * exponential of its augmented matrix, cached per step length).  The planes it leaves out (the complement) add to
 * output row r
 *
 *   s g_r(t) + D_r u(t-) + R_r(t):
 *
 *   D_r u(t-)    their quasi-static response, exact: added to the shadow's row (SHROW's D);
 *   g_r(t)       their free response from the initial state, a fixed function of time: tabulated (SHTAB, cubic
 *                Hermite between nodes k h) with a certified error per block of intervals (SHTERR); after the
 *                table its modes that matter continued exactly, Re sum_M Q_rM exp(mu_M (t - t_end)) (SHCONT,
 *                Q_rM = P_rM exp(mu_M t_end), the exponentials carried in the state over the steps, anchored
 *                exactly every BOUND_CONT_ANCHOR steps: cont_step, which derives its round-off allowance), the
 *                others (or, without a table, all) bounded by sum_g tail_rg exp(-alpha_g (t - t_end));
 *   |R_r(t)|  <= sum_j static_rj |u_j(t-)| + sum_jg H_rjg V_jg(t), V_jg = int exp(-alpha_g (t - tau)) |du_j(tau)|
 *                (the input's jumps and slopes weighted by the decay of group g, SHRATE): it saturates under a
 *                persistent input;
 *
 * plus |c_r| |E| int |w| e^{growth t} (the planes' round-off; growth, SHSCAL: the truth's e^{At} is a contraction up
 * to the round-off of the computed A) and |c_r| (1e-11 + 1e-15 n) (|w| + |s| |x0|) (floating point).
 * An output's bound is |model - (shadow + feedthrough + table)| + that (the density through
 * rho = sum_m pw rho0 / (1 + e_m), harness/rom/bounds.py output_bounds).  O(k_s m + m G) per doStep, no N.  The
 * same arithmetic as harness/rom/bounds.py run_shadow (not bit for bit: a bound, compared within tolerances).
 *
 * A parametric model (sections SHPIECE, SHPARAM, SHCPL): the planes are affine in c and d about the scene's c_ref,
 * Lambda_i(c, d) = [[-d, (c / c_ref) sigma_i], [-sigma_i, 0]], assembled with the model's operators once c and d
 * are fixed (rom_bound_assemble), and the complement's terms (D, the gains, two groups: the underdamped planes at
 * d / 2, the others at the slowest rate among them, and the initial state's decaying Hoelder sums, no table) are
 * computed there from the complement planes (harness/rom/bounds.py parametric_complement, the same formulas).
 */
#include "rom_internal.h"
#include "rom_numerics.h"

#include <stdio.h>
#include <stdlib.h>

/* the planes' step in four AVX2 lanes where the CPU has AVX2, picked per state (GCC x86-64 Linux, as rom_frozen.c's
 * ROM_CLONES; -DROM_NO_CLONES or -DROM_NO_LANES: never) */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(ROM_NO_CLONES) && !defined(ROM_NO_LANES) && (__GNUC__ >= 8)
#define BOUND_AVX2 1
#endif

#define BOUND_ROUNDOFF 1e-11           /* harness/rom/bounds.py ROUNDOFF */
#define BOUND_ROUNDOFF_STEP 1e-15      /* ... ROUNDOFF_STEP */
#define BOUND_SUM_ROUNDOFF 1e-12       /* ... SUM_ROUNDOFF */
#define BOUND_DEFECT 1e-7              /* harness/rom/planes.py DEFECT */
#define BOUND_CACHE 2                  /* step lengths whose plane maps are kept */
#define BOUND_MAX_INPUTS (1u + ROM_MAX_PORTS)
#define BOUND_MAX_GROUPS 8u
#define BOUND_GROUP 4u                 /* the rows' sums' slots per group (shadow_group) */
#define BOUND_GROUP_WORDS 2u
#define BOUND_MAX_CONT 65536u          /* the modes continued past the free response table at most (SHCONT) */
#define BOUND_CONT_ROUNDOFF 1e-13      /* harness/rom/bounds.py CONT_ROUNDOFF */
#define BOUND_CONT_ANCHOR 256.0        /* ... CONT_ANCHOR: the continued modes' steps between exact anchors */
#define BOUND_CHECK_LANES 4u        /* the error check's rows side by side (table_rows_exceed) */
#define BOUND_CHECK_ROWS ((ROM_MAX_PROBES + BOUND_CHECK_LANES - 1) / BOUND_CHECK_LANES * BOUND_CHECK_LANES)
/* No subnormal operand on the hot path (a subnormal product costs ~100 cycles on x86): the tails' decays after the
 * table and the weighted variations are kept at or above BOUND_DECAY_FLOOR once positive, and the complement's
 * positive gains and tails at or above BOUND_SIZE_FLOOR (bounds.py SIZE_FLOOR; the parametric sums here), so their
 * products stay normal numbers (>= 2^-900); each floor raises an upper bound, by at most ~1e-120 of the bound */
#define BOUND_DECAY_FLOOR 0x1p-500     /* harness/rom/bounds.py DECAY_FLOOR */
#define BOUND_DECAY_FLOOR_X 347.0      /* exp(-x) <= BOUND_DECAY_FLOOR for x >= this (> 500 ln 2 = 346.57) */
#define BOUND_SIZE_FLOOR 0x1p-400      /* ... SIZE_FLOOR */
#define BOUND_CONT_FOLD 3u             /* the rows whose continued sums the step forms (the velocity rows of group 0) */
#if defined(__GNUC__)
#define BOUND_INLINE static inline __attribute__((always_inline))   /* (the specialized copies: constants folded) */
#define BOUND_APART static __attribute__((noinline))   /* (a path kept out of its caller's frame) */
#else
#define BOUND_INLINE static inline
#define BOUND_APART static
#endif
_Static_assert((3u * ROM_MAX_PROBES + ROM_MAX_PORTS + 1u + BOUND_GROUP - 1u) / BOUND_GROUP <= 64u * BOUND_GROUP_WORDS,
               "the rows' sums' groups fit BoundState.groups' bits");

typedef struct {
    double h;                  /* 0: empty */
    int64_t used;
    double *Phi;               /* [planes][4]: each plane's 2 x 2 map by columns (Phi_00, Phi_10, Phi_01, Phi_11) */
    double *Phi2;              /* [planes / 2][8]: the same of planes 2 t and 2 t + 1 by columns side by side (Phi_00,
                                  Phi_10 of 2 t, of 2 t + 1, then Phi_01, Phi_11 of each): planes_quads' lanes */
    double *G0, *G1;           /* [order][inputs] */
    double decay[BOUND_MAX_GROUPS], slope[BOUND_MAX_GROUPS];   /* exp(-alpha h), (1 - exp(-alpha h)) / (alpha h) */
    double growth;             /* exp(mu h): the shadow's growth over the step (w_int) */
    int chain;                 /* every group's alpha h <= TAIL_CHAIN_X: the tails' decays chain over the step */
} BoundCache;

typedef struct {
    double *w;                 /* [order] the shadow's state */
    double *y;                 /* [slots] |w|^2, then C w of every row (row r in slot r + 1), by groups of four (and
                                  four more, never summed: table_quad_body's load of a quad's last rows) */
    double *ct;                /* [order][slots] (slot 0 unused), C transposed, then zeros: the groups after group 0,
                                  which group0_sums sums from C's rows themselves */
    uint64_t groups[BOUND_GROUP_WORDS];   /* bit g: y's group g holds the sums of this w; 0 whenever w changes (step,
                                  reset, restore; at most 3 x 100 probes + 4 ports + 1 slots: 77 groups) */
    double w_root;             /* |w| of this w while w_fresh (the step's end, or group 0's sums: the same sum) */
    int w_fresh;
    int avx2;                  /* the CPU has AVX2: planes_quads steps the planes (BOUND_AVX2) */
    int rows_read;             /* group 0's rows were read since the last step (the error check): the next step
                                  sums them while w is at hand; else it sums |w|^2 alone (the rows when read) */
    double V[BOUND_MAX_INPUTS * BOUND_MAX_GROUPS];    /* [inputs][groups] the weighted variations */
    double u_prev[BOUND_MAX_INPUTS];   /* the input at the end of the last step */
    double w_int;              /* int |w| dt so far (a bound) */
    double steps;              /* steps taken (the round-off allowance) */
    double started;            /* 1 once w holds s w0 and its steps (the first doStep), 0 before */
    double tail_tau;           /* the time since the start at which tail_decay holds (NaN: none) */
    double tail_decay[BOUND_MAX_GROUPS];   /* exp(-alpha_g (tau - t_end)) there: the rows' tails after the table */
    int tails_restored;        /* tail_decay came with a restored state (of the state's own c, d: a parametric
                                  shadow's assembly at them keeps it), until the chain moves on or an assembly */
    /* the continued modes past the table (SHCONT; cont_step): E_M = exp(mu_M (tau - t_end)) carried over the steps,
     * E_M <- E_M exp(mu_M h), anchored exactly (exp, cos, sin) at the first step past the table, after
     * BOUND_CONT_ANCHOR steps and where the step length changes (serialized: the same continuation after a restore) */
    double *cont_z;            /* [n_cont][2]: E_M (Re, Im) at cont_tau */
    double cont_tau;           /* the time since the start at which cont_z holds (NaN: none) */
    double cont_n;             /* the steps since cont_z was anchored (0 to BOUND_CONT_ANCHOR) */
    double cont_h;             /* the last step's length (0: none): a new length anchors */
    double cont_drift;         /* sum |tau_i - (tau_i-1 + h_i)| over the steps since the anchor [s]: the state's time
                                  against the steps' exact sum (each term exact: two_sum) */
    double cont_sum[BOUND_CONT_FOLD][2];   /* rows 0 to 2's sums sum_M (Re Q Re E, Im Q Im E) at cont_tau, formed in
                                  the step while E is at hand (the error check's velocity rows; not state) */
    int cont_summed;           /* cont_sum holds them (the step formed them: the check read the rows before it) */
    double *cont_r;            /* [n_cont][4]: R_M = exp(mu_M cont_rh) as (Re R, Im R, -Im R, Re R), the step's
                                  factor (not state: a function of the step length) */
    double cont_rh;            /* the step length of cont_r (0: none) */
    double *cont_e;            /* [n_cont][2]: E_M computed exactly at read_tau, where a row is read at a time the
                                  steps did not carry (not state: no row read changes the continuation) */
    double read_tau;           /* (NaN: none) */
    double *cont_rows;         /* [rows][2]: per row sum_M (|Re Q_rM| + |Im Q_rM|) and the same weighted by
                                  |Re mu_M| + |Im mu_M| (the round-off allowance, cont_allowance) */
    double cont_amax;          /* max_M |Re mu_M| + |Im mu_M| */
    double *chk;               /* [ceil(P / 4)][4 + 2 groups][4]: the probes' velocity rows' terms for the error check,
                                  four rows side by side (check_terms; not state: a function of the model's rows) */
    uint64_t chk_gen;          /* the model's rows' version chk holds (0: none yet) */
    size_t chk_tab[BOUND_CHECK_ROWS], chk_err[BOUND_CHECK_ROWS];   /* lane by lane the row's offsets in the table's
                                  rows (r nodes) and in SHTERR (r blocks) (the quads' last lanes past P: row P - 1's) */
    BoundCache cache[BOUND_CACHE];
    int64_t clock;
    double *work;              /* [4][n][n], n = 2 + 2 inputs (the exponential's matrices) */
    void *storage_;
} BoundState;

static const char *const TAGS[] = {"SHSCAL", "SHLAM", "SHB", "SHC", "SHW0", "SHROW", "SHRATE", "SHPROBE"};
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

/* ---- a parametric shadow's complement at (c, d) (harness/rom/bounds.py parametric_complement) ---- */

/* the rows' sums of a parametric shadow's complement (the row terms of SHROW's layout, rom.h RomBoundModel) */
typedef struct {
    double *row;               /* [rows][row_len] being summed */
    uint32_t rows, inputs, groups, row_len;
} RowSums;

/* one mode of group `group`: its transient gains |gamma'_r| bet_over_l[j] (bet_over_l[j] = |beta'_j| / |lambda|)
 * into H_rjg and its free response's size |gamma'_r| eta (eta = |eta'|) into the tail G_rg */
static void add_mode(RowSums *rs, uint32_t group, const double *gam, const double *bet_over_l, double eta) {
    const uint32_t m = rs->inputs, G = rs->groups;
    for (uint32_t r = 0; r < rs->rows; r++) {
        double *row = rs->row + (size_t)r * rs->row_len;
        for (uint32_t j = 0; j < m; j++) {
            const double gj = gam[r] * bet_over_l[j];
            if (gj > 0) row[1 + 2 * m + j * G + group] += gj;       /* inf stays inf: an unbounded transient */
        }
        row[1 + 2 * m + m * G + group] += gam[r] * eta;
    }
}

/* the complement planes' terms at (c, d) into b->storage_'s rows and rates: per plane the block
 * [[-d, st], [-st, 0]] in the energy coordinates of c (st = sqrt(c / c_ref) sigma, e coefficients times
 * sqrt(c_ref / c)), its modes in normal form (harness/rom/planes.py plane_modes), group 0 the underdamped ones at
 * d / 2, group 1 the others at the slowest of their rates */
static RomStatus assemble_complement(RomBoundModel *b, double c, double d, char *message, size_t message_size) {
    const uint32_t R = b->rows, m = b->inputs, G = 2, len = b->row_len, width = 2 + 2 * R + m;
    double *rows = b->storage_ + 4 * (size_t)b->planes, *rates = rows + (size_t)R * len;
    if (b->groups != G) return rom_fail(message, message_size, "resources: a parametric shadow has 2 groups");
    for (uint32_t r = 0; r < R; r++) {
        for (uint32_t k = 1; k < len; k++) rows[(size_t)r * len + k] = 0.0;
    }
    const double cs = sqrt(c / b->c_ref), es = sqrt(b->c_ref / c);
    double slow = INFINITY;
    RowSums rs = {rows, R, m, G, len};
    double gam[2 * (3 * ROM_MAX_PROBES + ROM_MAX_PORTS)], bet[BOUND_MAX_INPUTS];
    double *g2 = gam + R;
    for (uint32_t i = 0; i < b->n_cpl; i++) {
        const double *pl = b->cpl + (size_t)i * width;
        const double st = cs * pl[0], eta = pl[1];
        const double *ch = pl + 2, *bv = pl + 2 + 2 * R;
        /* D: c^T (-L^-1) (b, 0) = -c_e b / st (any d) */
        for (uint32_t r = 0; r < R; r++) {
            for (uint32_t j = 0; j < m; j++) rows[(size_t)r * len + 1 + j] += -(es * ch[2 * r + 1]) * bv[j] / st;
        }
        const double half = -0.5 * d, disc = 0.25 * d * d - st * st, size = fmax(d, st);
        if (fabs(disc) <= (BOUND_DEFECT * size) * (BOUND_DEFECT * size)) {      /* defective: no transform */
            const double N0 = 0.5 * d + st, alpha = 0.25 * d;
            const double scale = alpha > 0 && N0 > alpha ? (N0 / alpha) * exp(alpha / N0 - 1.0) :
                                 (alpha > 0 ? 1.0 : INFINITY);
            const double f2 = d * d + 2.0 * st * st, smin2 = 0.5 * (f2 - sqrt(fmax(f2 * f2 - 4.0 * pow(st, 4), 0.0)));
            const double smin = sqrt(fmax(smin2, 0.0));
            for (uint32_t r = 0; r < R; r++) gam[r] = hypot(ch[2 * r], es * ch[2 * r + 1]);
            for (uint32_t j = 0; j < m; j++) bet[j] = fabs(bv[j]) > 0 ? fabs(bv[j]) * scale / smin : 0.0;
            add_mode(&rs, 1, gam, bet, fabs(eta) * scale);
            slow = fmin(slow, alpha);
            continue;
        }
        if (disc < 0) {                 /* underdamped: T = [[st, 0], [d/2, w]], T^-1 = [[w, 0], [-d/2, st]] / (st w) */
            const double w = sqrt(-disc);
            for (uint32_t r = 0; r < R; r++) {
                const double cv = ch[2 * r], ce = es * ch[2 * r + 1];
                gam[r] = hypot(st * cv + 0.5 * d * ce, w * ce);                  /* |T^T c| */
            }
            for (uint32_t j = 0; j < m; j++) bet[j] = fabs(bv[j]) / (w * st);    /* |T^-1 (b, 0)| / |lambda| */
            add_mode(&rs, 0, gam, bet, fabs(eta) / w);
            continue;
        }
        /* overdamped: lambda_k = -d/2 +- sqrt(disc), v_k = (st, lambda_k + d) / |.|, two real modes */
        const double r0 = sqrt(disc), lam[2] = {half + r0, half - r0};
        double T[2][2];
        for (int k = 0; k < 2; k++) {
            const double n = hypot(st, lam[k] + d);
            T[0][k] = st / n;
            T[1][k] = (lam[k] + d) / n;
        }
        const double det = T[0][0] * T[1][1] - T[0][1] * T[1][0];
        const double Ti[2][2] = {{T[1][1] / det, -T[0][1] / det}, {-T[1][0] / det, T[0][0] / det}};
        for (int k = 0; k < 2; k++) {
            for (uint32_t r = 0; r < R; r++) {
                const double cv = ch[2 * r], ce = es * ch[2 * r + 1];
                g2[r] = fabs(T[0][k] * cv + T[1][k] * ce);
            }
            for (uint32_t j = 0; j < m; j++) bet[j] = fabs(Ti[k][0] * bv[j]) / fabs(lam[k]);
            add_mode(&rs, 1, g2, bet, fabs(Ti[k][0] * eta));
            slow = fmin(slow, -lam[k]);
        }
    }
    rates[0] = 0.5 * d;
    rates[1] = fmin(isfinite(slow) ? slow : 0.5 * d, 0.5 * d);
    for (uint32_t r = 0; r < R; r++) {
        double *row = rows + (size_t)r * len;
        for (uint32_t k = 1 + 2 * m; k < len; k++) {
            row[k] *= 1.0 + BOUND_SUM_ROUNDOFF;
            if (row[k] > 0 && row[k] < BOUND_SIZE_FLOOR) row[k] = BOUND_SIZE_FLOOR;
        }
    }
    return ROM_OK;
}

/* a parametric shadow at (c, d): Lambda_i = SHLAM_i + c piece_i[0:4] + d piece_i[4:8] (harness/rom/bounds.py
 * Shadow.blocks, the same order), mu, |E(c, d)| = sum_p coef_p (E_p,v + sqrt(c / c_ref) E_p,e) (coef 1, c, d:
 * Shadow.residual_norm), the e rows' scale sqrt(c_ref / c) (Shadow.dual_norms) and the complement's terms */
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
    b->generation++;                                    /* (the rows' terms change: the states' copies are stale) */
    return assemble_complement(b, c, d, message, message_size);
}

/* sections SHPIECE, SHPARAM, SHCPL (a parametric shadow: all three with PARAMS (SHCPL absent when every plane is
 * kept), or none); assembled at PARAMS' start */
static RomStatus prepare_pieces(RomModel *m, const RomSection *row_sec, const RomSection *rate_sec, char *message,
                                size_t message_size) {
    RomBoundModel *b = &m->bound;
    const RomSection *piece = rom_section(m, "SHPIECE"), *parm = rom_section(m, "SHPARAM");
    const RomSection *cpl = rom_section(m, "SHCPL"), *params = rom_section(m, "PARAMS");
    b->e_scale = 1.0;
    b->row = row_sec->data;
    b->rates = rate_sec->data;
    if (!piece && !parm && !cpl) {
        if (b->n_cpl) return rom_fail(message, message_size, "resources: SHSCAL counts complement planes without "
                                      "the parametric sections SHPIECE, SHPARAM, SHCPL");
        return ROM_OK;
    }
    if (!piece || !parm || !params || (b->n_cpl > 0) != (cpl != NULL) || b->nodes) {
        return rom_fail(message, message_size, "resources: the error bounds' sections SHPIECE and SHPARAM come "
                        "together, with the sections SH*, PARAMS and SHCPL when SHSCAL counts complement planes, "
                        "without SHTAB (a parametric model)");
    }
    if (shape(piece, b->planes, 8, message, message_size) != ROM_OK ||
        shape(parm, 1, ROM_SHPARAM_COLUMNS, message, message_size) != ROM_OK ||
        (cpl && shape(cpl, b->n_cpl, 2 + 2 * b->rows + b->inputs, message, message_size) != ROM_OK)) return ROM_FAIL;
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
    for (uint32_t i = 0; cpl && i < b->n_cpl; i++) {
        if (!(cpl->data[(size_t)i * cpl->cols] > 0)) {
            return rom_fail(message, message_size, "resources: section SHCPL's sigma = %g (allowed: > 0: the null "
                            "planes stay in the shadow)", cpl->data[(size_t)i * cpl->cols]);
        }
    }
    const size_t count = 4 * (size_t)b->planes + (size_t)b->rows * b->row_len + b->groups;
    b->storage_ = (double *)calloc(count, sizeof(double));
    if (!b->storage_) return rom_fail(message, message_size, "resources: out of memory (the error bounds' planes)");
    double *rows = b->storage_ + 4 * (size_t)b->planes;
    for (uint32_t r = 0; r < b->rows; r++) rows[(size_t)r * b->row_len] = row_sec->data[(size_t)r * b->row_len];
    b->row = rows;
    b->rates = rows + (size_t)b->rows * b->row_len;
    b->piece = piece->data;
    b->cpl = cpl ? cpl->data : NULL;
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
        if (!bs->tails_restored) bs->tail_tau = NAN;                    /* and the tails' decays of the old rates
                                                                           (a restored state's are of its c, d) */
        bs->tails_restored = 0;
    }
    return ROM_OK;
}

/* the modes continued past the table: section SHCONT (only with SHTAB; (1 + rows) x 2 n_cont, n_cont <= BOUND_MAX_CONT:
 * row 0 the exponents mu_M (Re <= 0: no mode grows), then per row the amplitudes at the table's end; finite: the
 * loader's check of every section) */
static RomStatus prepare_continuation(RomModel *m, char *message, size_t message_size) {
    RomBoundModel *b = &m->bound;
    const RomSection *cont = rom_section(m, "SHCONT");
    b->n_cont = 0;
    b->cont = NULL;
    if (!cont) return ROM_OK;
    if (!b->nodes) {
        return rom_fail(message, message_size, "resources: section SHCONT (the free response's modes past its "
                        "table) without the table's sections SHTAB and SHTERR");
    }
    if (cont->rows != 1 + b->rows || cont->cols % 2 != 0 || cont->cols / 2 > BOUND_MAX_CONT) {
        return rom_fail(message, message_size, "resources: section SHCONT is %u x %u, expected %u x 2 n (the error "
                        "bounds' modes past the table; n from 1 to %u)", cont->rows, cont->cols, 1 + b->rows,
                        BOUND_MAX_CONT);
    }
    for (uint32_t k = 0; k < cont->cols / 2; k++) {
        if (!(cont->data[2 * (size_t)k] <= 0)) {
            return rom_fail(message, message_size, "resources: section SHCONT's mode %u grows: Re mu = %g s^-1 "
                            "(allowed: <= 0)", k, cont->data[2 * (size_t)k]);
        }
    }
    b->n_cont = cont->cols / 2;
    b->cont = cont->data;
    return ROM_OK;
}

/* sections SHTAB and SHTERR (both or neither; SHSCAL's nodes > 0 with them) */
static RomStatus prepare_table(RomModel *m, char *message, size_t message_size) {
    RomBoundModel *b = &m->bound;
    const RomSection *tab = rom_section(m, "SHTAB"), *terr = rom_section(m, "SHTERR");
    if ((tab == NULL) != (terr == NULL) || (tab == NULL) != (b->nodes == 0)) {
        return rom_fail(message, message_size, "resources: the error bounds' sections SHTAB and SHTERR come "
                        "together, when SHSCAL's nodes > 0");
    }
    if (!tab) return prepare_continuation(m, message, message_size);      /* (refuses an SHCONT without table) */
    if (!(b->h_tab > 0) || b->nodes < 2 || b->q < 1) {
        return rom_fail(message, message_size, "resources: section SHSCAL's table (nodes %u, h %g s, q %u; allowed: "
                        "nodes >= 2, h > 0, q >= 1)", b->nodes, b->h_tab, b->q);
    }
    b->blocks = (b->nodes - 1 + b->q - 1) / b->q;
    if (shape(tab, 2 * b->rows, b->nodes, message, message_size) != ROM_OK ||
        shape(terr, b->rows, b->blocks, message, message_size) != ROM_OK) return ROM_FAIL;
    b->tab = tab->data;
    b->terr = terr->data;
    return prepare_continuation(m, message, message_size);
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
        if (rom_section(m, "SHPIECE") || rom_section(m, "SHPARAM") || rom_section(m, "SHCPL") ||
            rom_section(m, "SHTAB") || rom_section(m, "SHTERR") || rom_section(m, "SHCONT")) {
            return rom_fail(message, message_size, "resources: the error bounds' sections SHPIECE, SHPARAM, SHCPL, "
                            "SHTAB, SHTERR or SHCONT without the sections SH*");
        }
        return ROM_OK;
    }
    if (found != N_TAGS) {
        return rom_fail(message, message_size, "resources: the error bounds' sections SHSCAL, SHLAM, SHB, SHC, SHW0, "
                        "SHROW, SHRATE, SHPROBE come together (%zu of %zu present)", found, (size_t)N_TAGS);
    }
    const RomSection *scal = sec[0];
    if (shape(scal, 1, ROM_SHSCAL_COLUMNS, message, message_size) != ROM_OK) return ROM_FAIL;
    const double *v = scal->data;
    /* the shadow's inputs: f and each port force, or f alone where a port channel carries the ports exactly */
    const uint32_t all = 1u + m->n_ports, rows = 3u * m->n_probes + m->n_ports;
    const int channel = rom_section(m, "PCSCAL") != NULL;
    const int inputs_ok = v[ROM_SHSCAL_INPUTS] == (double)all || (channel && v[ROM_SHSCAL_INPUTS] == 1.0);
    if (!whole(v[ROM_SHSCAL_PLANES], 1, ROM_MAX_SHADOW_PLANES) || v[ROM_SHSCAL_ORDER] != 2.0 * v[ROM_SHSCAL_PLANES] ||
        !inputs_ok || v[ROM_SHSCAL_ROWS] != (double)rows || !whole(v[ROM_SHSCAL_NODES], 0, 1e7) ||
        !whole(v[ROM_SHSCAL_GROUPS], 1, BOUND_MAX_GROUPS) || !(v[ROM_SHSCAL_H_TAB] >= 0) ||
        !whole(v[ROM_SHSCAL_Q_TAB], 1, 1e7) || !(v[ROM_SHSCAL_X0_NORM] >= 0) || !(v[ROM_SHSCAL_E_NORM] >= 0) ||
        !(v[ROM_SHSCAL_B_NORM] >= 0) || !(v[ROM_SHSCAL_TOLERANCE] >= 0) || !whole(v[ROM_SHSCAL_CPLANES], 0, 1e7) ||
        !(v[ROM_SHSCAL_GROWTH] >= 0 && isfinite(v[ROM_SHSCAL_GROWTH]))) {
        return rom_fail(message, message_size, "resources: section SHSCAL (the error bounds' sizes) does not fit the "
                        "model (%u inputs%s, %u output rows expected; planes 1 to %u, groups 1 to %u)", all,
                        channel ? " or 1" : "", rows, ROM_MAX_SHADOW_PLANES, BOUND_MAX_GROUPS);
    }
    RomBoundModel *b = &m->bound;
    const uint32_t planes = (uint32_t)v[ROM_SHSCAL_PLANES], order = 2u * planes;
    const uint32_t inputs = (uint32_t)v[ROM_SHSCAL_INPUTS], groups = (uint32_t)v[ROM_SHSCAL_GROUPS];
    b->order = order;
    b->planes = planes;
    b->inputs = inputs;
    b->rows = rows;
    b->groups = groups;
    b->row_len = 1 + 2 * inputs + inputs * groups + groups;
    b->nodes = (uint32_t)v[ROM_SHSCAL_NODES];
    b->q = (uint32_t)v[ROM_SHSCAL_Q_TAB];
    b->n_cpl = (uint32_t)v[ROM_SHSCAL_CPLANES];
    b->h_tab = v[ROM_SHSCAL_H_TAB];
    b->t_end = b->nodes ? b->h_tab * (double)(b->nodes - 1) : 0.0;     /* (table_end) */
    b->inv_q = b->q ? 1.0 / (double)b->q : 0.0;                         /* (table_block) */
    if (shape(sec[1], planes, 4, message, message_size) != ROM_OK ||
        shape(sec[2], order, inputs, message, message_size) != ROM_OK ||
        shape(sec[3], rows, order, message, message_size) != ROM_OK ||
        shape(sec[4], 1, order, message, message_size) != ROM_OK ||
        shape(sec[5], rows, b->row_len, message, message_size) != ROM_OK ||
        shape(sec[6], 1, groups, message, message_size) != ROM_OK ||
        shape(sec[7], m->n_probes, 4, message, message_size) != ROM_OK) {
        memset(&m->bound, 0, sizeof m->bound);
        return ROM_FAIL;
    }
    /* SHRATE's rates are >= 0 (a value rule of the layout, rom_resources.c check_values) */
    b->x0_norm = v[ROM_SHSCAL_X0_NORM];
    b->e_norm = v[ROM_SHSCAL_E_NORM];
    b->b_norm = v[ROM_SHSCAL_B_NORM];
    b->tolerance = v[ROM_SHSCAL_TOLERANCE];
    b->growth = v[ROM_SHSCAL_GROWTH];
    b->mu = plane_growth(sec[1]->data, planes);
    b->lam = sec[1]->data;
    b->B = sec[2]->data;
    b->C = sec[3]->data;
    b->w0 = sec[4]->data;
    b->probe = sec[7]->data;
    if (prepare_table(m, message, message_size) != ROM_OK ||
        prepare_pieces(m, sec[5], sec[6], message, message_size) != ROM_OK) {
        free(b->storage_);
        memset(&m->bound, 0, sizeof m->bound);
        return ROM_FAIL;
    }
    b->generation++;                                    /* (>= 1: a new state's copies, version 0, are made anew) */
    return ROM_OK;
}

int rom_has_bounds(const RomModel *m) {
    return m && m->bound.order > 0;
}

/* the rows' sums' slots: |w|^2, the rows, rounded up to a whole group (shadow_group) */
static size_t row_slots(const RomBoundModel *b) {
    return (b->rows + 1 + BOUND_GROUP - 1) / BOUND_GROUP * BOUND_GROUP;
}

static int group_fresh(const BoundState *bs, size_t g) {
    return (int)((bs->groups[g / 64] >> (g % 64)) & 1u);
}

static void groups_stale(BoundState *bs) {
    for (unsigned i = 0; i < BOUND_GROUP_WORDS; i++) bs->groups[i] = 0;
    bs->w_fresh = 0;
}

/* per output row the continued modes' sums that their round-off allowance weighs (cont_allowance): sum_M q_rM and
 * sum_M q_rM a_M, q_rM = |Re Q_rM| + |Im Q_rM| (>= |Q_rM|), a_M = |Re mu_M| + |Im mu_M| (>= |mu_M|), and max_M a_M */
static void cont_rows(BoundState *bs, const RomBoundModel *b) {
    bs->cont_amax = 0.0;
    if (!bs || !b || !b->n_cont || !bs->cont_rows) return;
    for (uint32_t k = 0; k < b->n_cont; k++) {
        const double a = fabs(b->cont[2 * (size_t)k]) + fabs(b->cont[2 * (size_t)k + 1]);
        if (a > bs->cont_amax) bs->cont_amax = a;
    }
    for (uint32_t r = 0; r < b->rows; r++) {
        const double *Q = b->cont + 2 * (size_t)b->n_cont * (1 + (size_t)r);
        double sum = 0.0, weighted = 0.0;
        for (uint32_t k = 0; k < b->n_cont; k++) {
            const double q = fabs(Q[2 * (size_t)k]) + fabs(Q[2 * (size_t)k + 1]);
            sum += q;
            weighted += q * (fabs(b->cont[2 * (size_t)k]) + fabs(b->cont[2 * (size_t)k + 1]));
        }
        bs->cont_rows[2 * (size_t)r] = sum;
        bs->cont_rows[2 * (size_t)r + 1] = weighted;
    }
}

RomStatus rom_bound_state_new(RomState *s) {
    const RomBoundModel *b = &s->model->bound;
    s->bound = NULL;
    if (!b->order) return ROM_OK;
    BoundState *bs = (BoundState *)calloc(1, sizeof(BoundState));
    if (!bs) return ROM_FAIL;
    const size_t k = b->order, m = b->inputs, n = 2 + 2 * m;   /* a plane's augmented matrix's size */
    const size_t slots = row_slots(b);
    const size_t nc = 2 * (size_t)b->n_cont;
#define BOUND_ARRAYS 9
    const size_t quads = ((size_t)s->model->n_probes + BOUND_CHECK_LANES - 1) / BOUND_CHECK_LANES;
    size_t counts[BOUND_ARRAYS + 4 * BOUND_CACHE] = {k, slots + BOUND_CHECK_LANES, 4 * n * n, k * slots, nc, 2 * nc,
                                                     nc, b->n_cont ? 2 * (size_t)b->rows : 0,
                                                     quads * (4 + 2 * (size_t)b->groups) * BOUND_CHECK_LANES};
    double **ptrs[BOUND_ARRAYS + 4 * BOUND_CACHE] = {&bs->w, &bs->y, &bs->work, &bs->ct, &bs->cont_z, &bs->cont_r,
                                                     &bs->cont_e, &bs->cont_rows, &bs->chk};
    for (int c = 0; c < BOUND_CACHE; c++) {
        counts[BOUND_ARRAYS + 4 * c] = 4 * (size_t)b->planes;
        counts[BOUND_ARRAYS + 1 + 4 * c] = k * m;
        counts[BOUND_ARRAYS + 2 + 4 * c] = k * m;
        counts[BOUND_ARRAYS + 3 + 4 * c] = 4 * (size_t)b->planes;
        ptrs[BOUND_ARRAYS + 4 * c] = &bs->cache[c].Phi;
        ptrs[BOUND_ARRAYS + 1 + 4 * c] = &bs->cache[c].G0;
        ptrs[BOUND_ARRAYS + 2 + 4 * c] = &bs->cache[c].G1;
        ptrs[BOUND_ARRAYS + 3 + 4 * c] = &bs->cache[c].Phi2;
    }
    bs->storage_ = rom_alloc_arrays(counts, ptrs, BOUND_ARRAYS + 4 * BOUND_CACHE);
#undef BOUND_ARRAYS
    if (!bs->storage_) {
        free(bs);
        return ROM_FAIL;
    }
    for (size_t i = 0; i < k; i++) {             /* (rom_alloc_arrays' arrays start zeroed or are all written) */
        double *col = bs->ct + i * slots;
        for (size_t r = 1; r < slots; r++) col[r] = r <= b->rows ? b->C[(r - 1) * k + i] : 0.0;
    }
    cont_rows(bs, b);
    bs->tail_tau = bs->cont_tau = bs->read_tau = NAN;
#if defined(BOUND_AVX2)
    bs->avx2 = __builtin_cpu_supports("avx2") != 0;
#endif
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
    groups_stale(bs);
    for (uint32_t i = 0; i < BOUND_MAX_INPUTS * BOUND_MAX_GROUPS; i++) bs->V[i] = 0.0;
    for (uint32_t i = 0; i < BOUND_MAX_INPUTS; i++) bs->u_prev[i] = 0.0;
    bs->w_int = bs->steps = bs->started = 0.0;
    bs->tail_tau = bs->cont_tau = bs->read_tau = NAN;
    bs->cont_n = bs->cont_h = bs->cont_drift = 0.0;
    bs->cont_summed = bs->tails_restored = 0;
    for (uint32_t g = 0; g < BOUND_MAX_GROUPS; g++) bs->tail_decay[g] = 0.0;      /* (a reset's state as a new one's) */
    for (size_t i = 0; i < 2 * (size_t)s->model->bound.n_cont; i++) bs->cont_z[i] = 0.0;
    for (int c = 0; c < BOUND_CACHE; c++) bs->cache[c].h = 0.0;      /* the maps stay valid; kept empty anyway */
}

/* the free response table's end [s] (0: no table): h_tab (nodes - 1), computed when the section was read */
static double table_end(const RomBoundModel *b) {
    return b ? b->t_end : 0.0;
}

/* The continued modes past the table (SHCONT): row r adds Re sum_M Q_rM E_M, E_M = exp(mu_M x), x = tau - t_end,
 * Q_rM = P_rM exp(mu_M t_end).  E_M is carried in the state over the steps, E_M <- E_M R_M, R_M = exp(mu_M h)
 * computed once per step length (a complex product per mode and step, where an exact E_M costs an exp and a
 * sincos), and anchored, E_M computed exactly from the time (cont_exact), at the first step past the table, after
 * BOUND_CONT_ANCHOR steps and at a step whose length is not the last one's (cont_step).  The round-off allowance
 * (harness/rom/bounds.py cont_roundoff, the same formula; u = 2^-53, a_M = |Re mu_M| + |Im mu_M| >= |mu_M|, n the
 * steps since the anchor, tau = tau_n the time since the start, the state's, taken as the truth's time):
 * - the anchor at tau_a: t_end = h_tab (nodes - 1) here, within 2 u t_end of bounds.py's (its Q's exp(mu t_end)),
 *   x rounded (u x), mu x rounded (u |mu| x), Q's own exp(mu t_end) rounded (u |mu| t_end): the argument is off by
 *   |delta| <= 3 u |mu| tau_a, so E_M by 1.001 |delta| of |E_M| (|delta| <= 1e-3); exp, cos, sin within an ulp each
 *   and the products |E| cos, |E| sin rounded: 3 u more: eps_0 <= 3 u + 3.003 u a_M tau_a;
 * - a step: R_M within (6.3 + a_M h) u of exp(mu_M h) (exp 2 u, cos and sin 2 sqrt(2) u, the products sqrt(2) u, the
 *   arguments mu h rounded u a_M h), the product E R within 2 sqrt(2) u of |E R| (no fused multiply-add: each part
 *   two products and a sum rounded): g_i = (12 + a_M h_i) u; and the time: the state's tau_i is tau_i-1 + h_i
 *   rounded (rom.c), d_i = |tau_i - (tau_i-1 + h_i)| off the steps' exact sum, which E carries (two_sum_error, exact;
 *   summed in cont_drift, D = sum d_i): a_M D of E_M.  The relative error after n steps is eps_n <= (1 + g)^n (1 +
 *   eps_0) - 1 + 1.001 a_M D <= 1.002 (eps_0 + sum_i g_i + a_M D) where that is <= 1e-3, and sum_i a_M h_i <= a_M
 *   (tau - tau_a) (tau_a <= tau): eps_n <= 1.002 (u (3 + 12 n + 4 a_M tau) + a_M D);
 * - the row's sum of n_c terms Re Q E = Re Q Re E - Im Q Im E (two lanes, sum_M Re Q Re E and sum_M Im Q Im E, each
 *   product rounded, added in order, then their difference): (n_c + 1) u sum_M q_rM |E_M| (q = |Re Q| + |Im Q|), and
 *   Q's relative error (bounds.py's P, as the table's nodes'): BOUND_CONT_ROUNDOFF.
 * With |E_M| <= 1 (Re mu_M <= 0: prepare_continuation) the allowance is, per row, k0 sum_M q_rM + k1 sum_M q_rM a_M
 * (cont_rows) with k0 = 1.01 (BOUND_CONT_ROUNDOFF + (n_c + 8 + 12 n) u), k1 = 1.01 (4 u tau + D) (the 1.01 and the 8
 * cover 1.002 x 1.001, the sums' own rounding and the products of small terms), infinite where (12 n + 4 max_M a_M
 * tau) u + max_M a_M D > 1e-3 (beyond |mu| tau ~ 1e12 rad: no bound).  O(1) per row: the modes' sizes, 1e-13 of
 * the free response, stay below the shadow's own round-off allowance (1e-11 of |c_r| |x0|) without their decay. */

/* E_M = exp(mu_M x) (Re, Im) of every continued mode into out[2 n_cont]: an exp and a sincos (exactly 1 and 0 where
 * Re mu, Im mu are 0, no libm call) */
static void cont_exact(const RomBoundModel *b, double x, double *out) {
    for (uint32_t k = 0; k < b->n_cont; k++) {
        const double re = b->cont[2 * (size_t)k], im = b->cont[2 * (size_t)k + 1];
        const double size = re != 0.0 ? exp(re * x) : 1.0, phase = im * x;
        out[2 * (size_t)k] = im != 0.0 ? size * cos(phase) : size;
        out[2 * (size_t)k + 1] = im != 0.0 ? size * sin(phase) : 0.0;
    }
}

/* exp(-x) rounded up for the tails' chain: a libm exp within a few ulps, the chain's two roundings and the rounding
 * of x = alpha h (up to TAIL_CHAIN_X: below 2 ulps) stay well inside the factor 1 + 2^-48 (16 ulps) per step; it
 * loosens the tail by 1 + 3.6e-15 a step (1e-8 after 10^6 steps) */
#define TAIL_UP (1.0 + 3.552713678800501e-15)
#define TAIL_CHAIN_X 4.0

/* k / q, the error block of the table's interval k (q >= 1), without an integer division (tens of cycles each
 * step): k times 1 / q rounded is within one of the quotient (k < 2^32), which one comparison each way corrects */
static inline uint32_t table_block(const RomBoundModel *b, uint32_t k) {
    uint32_t B = (uint32_t)((double)k * b->inv_q);
    if ((uint64_t)B * b->q > k) {
        B--;
    } else if ((uint64_t)(B + 1) * b->q <= k) {
        B++;
    }
    return B;
}

/* exp(-x), x >= 0, at least BOUND_DECAY_FLOOR (an upper bound of it; no libm call where it underflows there) */
static inline double floored_decay(double x) {
    return x >= BOUND_DECAY_FLOOR_X ? BOUND_DECAY_FLOOR : fmax(exp(-x), BOUND_DECAY_FLOOR);
}

/* a decay chained over a step: d times the step's exp(-alpha h) rounded up (TAIL_UP), at least BOUND_DECAY_FLOOR */
static inline double chained_decay(double d, double step) {
    return fmax(d * step * TAIL_UP, BOUND_DECAY_FLOOR);
}

/* the groups' decay of the rows' tails at tau after the table's end, once for every row (rom_bound_step, the step
 * of length h = c->h from t0 = tau - h): exp(-alpha_g (tau - t_end)), or, where the last step left them at t0
 * after the table's end, those times this step's exp(-alpha_g h) (c->decay) rounded up (TAIL_UP): never below
 * the decay over the steps' own sum, without an exponential per group and step */
BOUND_INLINE void tail_decays(BoundState *bs, const RomBoundModel *b, double tau, double t0,
                              const BoundCache *c, double h) {
    const double t_end = table_end(b), over = tau - t_end;
    const int chain = bs->tail_tau == t0 && t0 > t_end && h == c->h;
    bs->tail_tau = tau;
    bs->tails_restored = 0;                             /* (the chain moved on: an assembly now is of new rates) */
    if (chain && c->chain && over > 0) {                /* every group chains (the loop's second case, the same
                                                           bits): the common step past the table, one test a step */
        for (uint32_t g = 0; g < b->groups; g++) {
            bs->tail_decay[g] = chained_decay(bs->tail_decay[g], c->decay[g]);
        }
        return;
    }
    for (uint32_t g = 0; g < b->groups; g++) {
        if (!(over > 0)) {
            bs->tail_decay[g] = 1.0;
        } else if (chain && b->rates[g] * h <= TAIL_CHAIN_X) {
            bs->tail_decay[g] = chained_decay(bs->tail_decay[g], c->decay[g]);
        } else {
            bs->tail_decay[g] = floored_decay(b->rates[g] * over);
        }
    }
}

/* the plane maps of a step h: per plane the exponential of [[L h, B_p h, 0], [0, 0, I], [0, 0, 0]],
 * and the groups' weights of a jump at the step's start and of a slope over it */
static const BoundCache *plane_maps(BoundState *bs, const RomBoundModel *b, double h) {
    bs->clock++;
    for (int c = 0; c < BOUND_CACHE; c++) {
        if (rom_same_step(h, bs->cache[c].h)) {     /* (an importer's jitter of a few ulps: the same step) */
            bs->cache[c].used = bs->clock;
            return &bs->cache[c];
        }
    }
    BoundCache *slot = &bs->cache[0];
    for (int c = 1; c < BOUND_CACHE; c++) {
        if (bs->cache[c].used < slot->used) slot = &bs->cache[c];
    }
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
            for (size_t j = 0; j < 2; j++) slot->Phi[4 * p + 2 * j + i] = E[i * n + j];
            for (size_t c = 0; c < m; c++) {
                slot->G0[(2 * p + i) * m + c] = E[i * n + 2 + c];
                slot->G1[(2 * p + i) * m + c] = E[i * n + 2 + m + c];
            }
        }
    }
    for (uint32_t t = 0; t < b->planes / 2; t++) {      /* planes 2 t and 2 t + 1 by columns side by side */
        for (size_t i = 0; i < 2; i++) {
            for (size_t l = 0; l < 2; l++) {
                slot->Phi2[8 * t + 4 * i + l] = slot->Phi[8 * t + 2 * i + l];
                slot->Phi2[8 * t + 4 * i + 2 + l] = slot->Phi[8 * t + 4 + 2 * i + l];
            }
        }
    }
    slot->chain = 1;
    for (uint32_t g = 0; g < b->groups; g++) {          /* harness/rom/bounds.py step_weights */
        const double x = b->rates[g] * h;
        slot->decay[g] = exp(-x);
        slot->slope[g] = x > 1e-8 ? -expm1(-x) / x : 1.0 - 0.5 * x;
        slot->chain &= x <= TAIL_CHAIN_X;               /* (tail_decays' test: the same product) */
    }
    slot->growth = exp(b->mu * h);
    slot->h = h;
    slot->used = bs->clock;
    return slot;
}

/* the inputs over the step: u (its value at the step's start) and du (its change over the step); the shadow's
 * first `inputs` of f, F_j / area */
static void step_inputs(const RomState *s, double h, double *u, double *du) {
    u[0] = s->f;
    du[0] = s->f_rate * h;
    for (uint32_t j = 0; j + 1 < s->model->bound.inputs; j++) {
        u[1 + j] = s->port_force[j] / s->area;
        du[1 + j] = s->port_rate[j] * h / s->area;
    }
}

static void shadow_group(const RomState *s, BoundState *bs, size_t g);

/* Two lanes side by side (four in the planes' step with AVX2: planes_quads): GCC/Clang vector extensions (an SSE2
 * register on x86-64), plain arrays elsewhere (or with -DROM_NO_LANES: tests/test_bound_step_cost.py compares the builds);
 * every lane does the scalar IEEE operation, in the same order (as rom_frozen.c's blocks).  Loads through memcpy:
 * the rows need no alignment. */
#if defined(__GNUC__) && !defined(ROM_NO_LANES)
#define BOUND_LANES 1
typedef double BoundLanes __attribute__((vector_size(16)));
#define LANES_LOAD(v, p) memcpy(&(v), (p), sizeof(BoundLanes))
#endif

/* group 0 of the rows' sums (|w|^2 in slot 0, C_r w of rows 0 to 2 in slots 1 to 3: the velocity rows the error
 * check reads with up to three probes) from C's rows themselves: four partial sums per slot side by side (the
 * coefficients i = 0, 1, 2, 3 mod 4, then (a0 + a1) + (a2 + a3)): group_sums' products and order */
static void group0_sums(const RomBoundModel *b, const double *w, double *out) {
    const size_t k = b->order;                       /* even: k mod 4 is 0 or 2 */
    const double *C0 = b->C, *C1 = C0 + k, *C2 = C1 + k;
    size_t i = 0;
#if defined(BOUND_LANES)
    /* (named, not an array: kept in registers) the partials 0, 1 (lo) and 2, 3 (hi) of the four slots */
    BoundLanes s0lo = {0.0, 0.0}, s0hi = s0lo, s1lo = s0lo, s1hi = s0lo, s2lo = s0lo, s2hi = s0lo, s3lo = s0lo,
               s3hi = s0lo;
    BoundLanes xlo, xhi, rlo, rhi;
    for (; i + 4 <= k; i += 4) {
        LANES_LOAD(xlo, w + i);
        LANES_LOAD(xhi, w + i + 2);
        s0lo += xlo * xlo;
        s0hi += xhi * xhi;
        LANES_LOAD(rlo, C0 + i);
        LANES_LOAD(rhi, C0 + i + 2);
        s1lo += rlo * xlo;
        s1hi += rhi * xhi;
        LANES_LOAD(rlo, C1 + i);
        LANES_LOAD(rhi, C1 + i + 2);
        s2lo += rlo * xlo;
        s2hi += rhi * xhi;
        LANES_LOAD(rlo, C2 + i);
        LANES_LOAD(rhi, C2 + i + 2);
        s3lo += rlo * xlo;
        s3hi += rhi * xhi;
    }
    if (i < k) {                                     /* the last two coefficients: partials 0, 1 */
        LANES_LOAD(xlo, w + i);
        s0lo += xlo * xlo;
        LANES_LOAD(rlo, C0 + i);
        s1lo += rlo * xlo;
        LANES_LOAD(rlo, C1 + i);
        s2lo += rlo * xlo;
        LANES_LOAD(rlo, C2 + i);
        s3lo += rlo * xlo;
    }
    out[0] = (s0lo[0] + s0lo[1]) + (s0hi[0] + s0hi[1]);
    out[1] = (s1lo[0] + s1lo[1]) + (s1hi[0] + s1hi[1]);
    out[2] = (s2lo[0] + s2lo[1]) + (s2hi[0] + s2hi[1]);
    out[3] = (s3lo[0] + s3lo[1]) + (s3hi[0] + s3hi[1]);
#else
    double a[BOUND_GROUP][4] = {{0.0}};              /* [slot][partial] */
    for (; i < k; i++) {
        const size_t l = i % 4;
        a[0][l] += w[i] * w[i];
        a[1][l] += C0[i] * w[i];
        a[2][l] += C1[i] * w[i];
        a[3][l] += C2[i] * w[i];
    }
    for (size_t c = 0; c < BOUND_GROUP; c++) out[c] = (a[c][0] + a[c][1]) + (a[c][2] + a[c][3]);
#endif
}

/* one plane of a one-input shadow over the step, its two coordinates side by side (lane l: Phi_l0 w0 + Phi_l1 w1 +
 * G0_l u0, + G1_l du0 unless held; Phi, G0, G1 the plane's: Phi by columns) into w, and their terms of group 0's
 * sums into acc[slot]'s lanes (the partial sums (2 p + l) mod 4: acc holds the even planes' or the odd planes'):
 * |w|^2 in slot 0, with `rows` also C_r w of rows 0 to 2 in slots 1 to 3 (C the plane's first column of C's rows,
 * rows k apart) */
#if defined(BOUND_LANES)
BOUND_INLINE void plane_lanes(const double *restrict Phi, const double *restrict G0, const double *restrict G1,
                              double *restrict w, const double *restrict C, size_t k, double u0, double du0,
                              int held, int rows, BoundLanes *acc) {
    BoundLanes c0, c1, g0, n;
    LANES_LOAD(c0, Phi);
    LANES_LOAD(c1, Phi + 2);
    LANES_LOAD(g0, G0);
    const BoundLanes w0 = {w[0], w[0]}, w1 = {w[1], w[1]}, u = {u0, u0};
    if (held) {
        n = c0 * w0 + c1 * w1 + g0 * u;
    } else {
        BoundLanes g1;
        LANES_LOAD(g1, G1);
        const BoundLanes du = {du0, du0};
        n = c0 * w0 + c1 * w1 + (g0 * u + g1 * du);
    }
    w[0] = n[0];
    w[1] = n[1];
    acc[0] += n * n;
    if (rows) {
        for (size_t r = 0; r + 1 < BOUND_GROUP; r++) {
            BoundLanes cr;
            LANES_LOAD(cr, C + r * k);
            acc[r + 1] += cr * n;
        }
    }
}
#else
BOUND_INLINE void plane_lanes(const double *restrict Phi, const double *restrict G0, const double *restrict G1,
                              double *restrict w, const double *restrict C, size_t k, double u0, double du0,
                              int held, int rows, double (*acc)[2]) {
    const double w0 = w[0], w1 = w[1];
    for (size_t l = 0; l < 2; l++) {
        const double n = held ? Phi[l] * w0 + Phi[2 + l] * w1 + G0[l] * u0 :
                                Phi[l] * w0 + Phi[2 + l] * w1 + (G0[l] * u0 + G1[l] * du0);
        w[l] = n;
        acc[0][l] += n * n;
        for (size_t r = 0; rows && r + 1 < BOUND_GROUP; r++) acc[r + 1][l] += C[r * k + l] * n;
    }
}
#endif

/* the planes of a one-input shadow over the step (u0 the input at its start, du0 its change over it; held: du0 =
 * 0, the slope's products, exact zeros, skipped) and group 0's sums of the new w while it is at hand, in
 * group_sums' partial sums and order (planes 2 t and 2 t + 1 are coordinates 4 t to 4 t + 3): |w|^2 for the next
 * step's start, and the velocity rows where `rows` (group 0's rows were read since the last step: the error check
 * reads them after every step until it warns; else they are summed when read) */
BOUND_INLINE void planes_one(BoundState *bs, const BoundCache *c, const RomBoundModel *b, double u0, double du0,
                             int held, int rows) {
    const uint32_t planes = b->planes;
    const size_t k = b->order;
    double *w = bs->w;
    const double *restrict Phi = c->Phi, *restrict G0 = c->G0, *restrict G1 = c->G1, *restrict C = b->C;
    uint32_t p = 0;
#if defined(BOUND_LANES)
    BoundLanes even[BOUND_GROUP], odd[BOUND_GROUP];
    for (size_t r = 0; r < BOUND_GROUP; r++) even[r] = odd[r] = (BoundLanes){0.0, 0.0};
#else
    double even[BOUND_GROUP][2] = {{0.0}}, odd[BOUND_GROUP][2] = {{0.0}};
#endif
    for (; p + 2 <= planes; p += 2, Phi += 8, G0 += 4, G1 += 4, w += 4, C += 4) {
        plane_lanes(Phi, G0, G1, w, C, k, u0, du0, held, rows, even);
        plane_lanes(Phi + 4, G0 + 2, G1 + 2, w + 2, C + 2, k, u0, du0, held, rows, odd);
    }
    if (p < planes) plane_lanes(Phi, G0, G1, w, C, k, u0, du0, held, rows, even);     /* an odd count's last */
    groups_stale(bs);
    for (size_t r = 0; r < (rows ? BOUND_GROUP : 1u); r++) {
        bs->y[r] = (even[r][0] + even[r][1]) + (odd[r][0] + odd[r][1]);
    }
    if (rows) bs->groups[0] |= 1u;
    bs->w_root = sqrt(bs->y[0]);
    bs->w_fresh = 1;
}

#if defined(BOUND_AVX2)
/* Four lanes (one AVX register): planes 2 t and 2 t + 1, coordinates 4 t to 4 t + 3, side by side, where the CPU has
 * AVX2 (BoundState.avx2; else planes_one's two lanes); each lane does planes_one's scalar IEEE operations in the same
 * order: the same bits */
typedef double BoundQuad __attribute__((vector_size(32)));
typedef int64_t BoundQuadBits __attribute__((vector_size(32)));
#define QUAD_LOAD(v, p) memcpy(&(v), (p), sizeof(BoundQuad))
#define QUAD_STORE(p, v) memcpy((p), &(v), sizeof(BoundQuad))

/* the planes of a one-input shadow over the step (lane l of planes 2 t, 2 t + 1: Phi_l0 w0 + Phi_l1 w1 + G0_l u0,
 * + G1_l du0 unless held, each plane's own w0, w1) into w, and group 0's sums of the new w into out[slot]: four
 * partial sums per slot, lane l holding the coordinates l mod 4 (group_sums' partials), then (a0 + a1) + (a2 + a3):
 * |w|^2 in slot 0, with `rows` also C_r w of rows 0 to 2 in slots 1 to 3 (C's rows k apart) */
BOUND_INLINE void quads_body(double *restrict w, const BoundCache *c, const RomBoundModel *b, double u0, double du0,
                             int held, int rows, double *restrict out) {
    const uint32_t planes = b->planes;
    const size_t k = b->order;
    const double *restrict P2 = c->Phi2, *restrict G0 = c->G0, *restrict G1 = c->G1, *restrict C = b->C;
    const BoundQuad zero = {0.0, 0.0, 0.0, 0.0}, u = {u0, u0, u0, u0}, du = {du0, du0, du0, du0};
    BoundQuad a0 = zero, a1 = zero, a2 = zero, a3 = zero;
    const size_t quads = 4 * (size_t)(planes / 2);     /* planes 2 t and 2 t + 1: coordinates i = 4 t to 4 t + 3 */
    for (size_t i = 0; i < quads; i += 4) {            /* (one index for every array: the loop's own work least) */
        BoundQuad x, c0, c1, g0, n;
        QUAD_LOAD(x, w + i);
        QUAD_LOAD(c0, P2 + 2 * i);
        QUAD_LOAD(c1, P2 + 2 * i + 4);
        QUAD_LOAD(g0, G0 + i);
        const BoundQuad x0 = {x[0], x[0], x[2], x[2]}, x1 = {x[1], x[1], x[3], x[3]};
        if (held) {
            n = c0 * x0 + c1 * x1 + g0 * u;
        } else {
            BoundQuad g1;
            QUAD_LOAD(g1, G1 + i);
            n = c0 * x0 + c1 * x1 + (g0 * u + g1 * du);
        }
        QUAD_STORE(w + i, n);
        a0 += n * n;
        if (rows) {
            BoundQuad r0, r1, r2;
            QUAD_LOAD(r0, C + i);
            QUAD_LOAD(r1, C + k + i);
            QUAD_LOAD(r2, C + 2 * k + i);
            a1 += r0 * n;
            a2 += r1 * n;
            a3 += r2 * n;
        }
    }
    const uint32_t p = planes / 2 * 2;
    w += quads;
    G0 += quads;
    G1 += quads;
    C += quads;
    if (p < planes) {             /* an odd count's last plane: lanes 0 and 1; lanes 2 and 3 add 0 * 0 = +0, which
                                     leaves a sum as it is (never -0: it starts at +0) */
        const double *Phi = c->Phi + 4 * (size_t)p;
        const double w0 = w[0], w1 = w[1];
        double n[2];
        for (size_t l = 0; l < 2; l++) {
            n[l] = held ? Phi[l] * w0 + Phi[2 + l] * w1 + G0[l] * u0 :
                          Phi[l] * w0 + Phi[2 + l] * w1 + (G0[l] * u0 + G1[l] * du0);
            w[l] = n[l];
        }
        const BoundQuad nt = {n[0], n[1], 0.0, 0.0};
        a0 += nt * nt;
        if (rows) {
            const BoundQuad r0 = {C[0], C[1], 0.0, 0.0}, r1 = {C[k], C[k + 1], 0.0, 0.0},
                            r2 = {C[2 * k], C[2 * k + 1], 0.0, 0.0};
            a1 += r0 * nt;
            a2 += r1 * nt;
            a3 += r2 * nt;
        }
    }
    if (rows) {                   /* the four slots' (a0 + a1) + (a2 + a3) side by side: the same sums */
        const BoundQuadBits even = {0, 4, 2, 6}, odd = {1, 5, 3, 7}, low = {0, 1, 4, 5}, high = {2, 3, 6, 7};
        const BoundQuad s01 = __builtin_shuffle(a0, a1, even) + __builtin_shuffle(a0, a1, odd);
        const BoundQuad s23 = __builtin_shuffle(a2, a3, even) + __builtin_shuffle(a2, a3, odd);
        const BoundQuad sums = __builtin_shuffle(s01, s23, low) + __builtin_shuffle(s01, s23, high);
        QUAD_STORE(out, sums);
    } else {
        out[0] = (a0[0] + a0[1]) + (a0[2] + a0[3]);
    }
}

/* quads_body's four cases, each with its constants (held: du0 = 0, the slope's products, exact zeros, skipped) */
__attribute__((target("avx2"))) static void planes_quads(double *w, const BoundCache *c, const RomBoundModel *b,
                                                        double u0, double du0, int held, int rows, double *out) {
    if (!w || !c || !b || !out) return;
    if (held && rows) quads_body(w, c, b, u0, 0.0, 1, 1, out);
    else if (held) quads_body(w, c, b, u0, 0.0, 1, 0, out);
    else if (rows) quads_body(w, c, b, u0, du0, 0, 1, out);
    else quads_body(w, c, b, u0, du0, 0, 0, out);
}
#endif

static void plane_step_one(BoundState *bs, const BoundCache *c, const RomBoundModel *b, double u0, double du0,
                           int held) {
    const int rows = bs->rows_read;
    bs->rows_read = 0;
#if defined(BOUND_AVX2)
    if (bs->avx2) {                                             /* four lanes: planes_one's sums, the same bits */
        planes_quads(bs->w, c, b, u0, held ? 0.0 : du0, held, rows, bs->y);
        groups_stale(bs);
        if (rows) bs->groups[0] |= 1u;
        bs->w_root = sqrt(bs->y[0]);
        bs->w_fresh = 1;
        return;
    }
#endif
    if (held && rows) planes_one(bs, c, b, u0, 0.0, 1, 1);      /* the four cases, each with its constants */
    else if (held) planes_one(bs, c, b, u0, 0.0, 1, 0);
    else if (rows) planes_one(bs, c, b, u0, du0, 0, 1);
    else planes_one(bs, c, b, u0, du0, 0, 0);
}

/* the continued modes' sums of row r (its Q, 2 n_cont, the E_M's at hand): the two lanes sum_M Re Q_rM Re E_M and
 * sum_M Im Q_rM Im E_M (the row's value Re sum Q E is their difference), each as the even modes' sum plus the odd
 * modes' (each in the modes' order: the order of cont_rotate's lanes and of cont_quads' four), whoever asks (the
 * step's fold, cont_step, or a row read, free_part): the same bits */
#if defined(BOUND_LANES)
BOUND_INLINE void cont_row_sums(const double *restrict Q, const double *restrict E, uint32_t n, double *out) {
    BoundLanes even = {0.0, 0.0}, odd = even, q, e;
    uint32_t k = 0;
    for (; k + 2 <= n; k += 2) {
        LANES_LOAD(q, Q + 2 * (size_t)k);
        LANES_LOAD(e, E + 2 * (size_t)k);
        even += q * e;
        LANES_LOAD(q, Q + 2 * (size_t)k + 2);
        LANES_LOAD(e, E + 2 * (size_t)k + 2);
        odd += q * e;
    }
    if (k < n) {
        LANES_LOAD(q, Q + 2 * (size_t)k);
        LANES_LOAD(e, E + 2 * (size_t)k);
        even += q * e;
    }
    out[0] = even[0] + odd[0];
    out[1] = even[1] + odd[1];
}
#else
BOUND_INLINE void cont_row_sums(const double *restrict Q, const double *restrict E, uint32_t n, double *out) {
    double acc[2][2] = {{0.0}};                          /* [even, odd][lane] */
    for (uint32_t k = 0; k < n; k++) {
        acc[k % 2][0] += Q[2 * (size_t)k] * E[2 * (size_t)k];
        acc[k % 2][1] += Q[2 * (size_t)k + 1] * E[2 * (size_t)k + 1];
    }
    out[0] = acc[0][0] + acc[1][0];
    out[1] = acc[0][1] + acc[1][1];
}
#endif

/* E_M <- E_M R_M for every mode (R as (Re R, Im R, -Im R, Re R): lane 0 Re E Re R + Im E (-Im R), lane 1 Re E Im R +
 * Im E Re R, each product rounded, then their sum: the complex product's IEEE operations) and, with `fold` rows
 * (rows 0 to fold - 1), their sums of the new E_M (cont_row_sums' lanes, products and order) into sum */
#if defined(BOUND_LANES)
BOUND_INLINE void cont_rotate(double *restrict z, const double *restrict R, const double *restrict Q, size_t row,
                              uint32_t n, uint32_t fold, double (*sum)[2]) {
    BoundLanes acc[2][BOUND_CONT_FOLD];                  /* [even, odd][row] */
    for (uint32_t r = 0; r < BOUND_CONT_FOLD; r++) acc[0][r] = acc[1][r] = (BoundLanes){0.0, 0.0};
    for (uint32_t k = 0; k < n; k++, z += 2, R += 4, Q += 2) {
        BoundLanes r0, r1, q;
        LANES_LOAD(r0, R);
        LANES_LOAD(r1, R + 2);
        const BoundLanes zr = {z[0], z[0]}, zi = {z[1], z[1]};
        const BoundLanes e = zr * r0 + zi * r1;
        z[0] = e[0];
        z[1] = e[1];
        for (uint32_t r = 0; r < fold; r++) {
            LANES_LOAD(q, Q + r * row);
            acc[k % 2][r] += q * e;
        }
    }
    for (uint32_t r = 0; r < fold; r++) {
        sum[r][0] = acc[0][r][0] + acc[1][r][0];
        sum[r][1] = acc[0][r][1] + acc[1][r][1];
    }
}
#else
BOUND_INLINE void cont_rotate(double *restrict z, const double *restrict R, const double *restrict Q, size_t row,
                              uint32_t n, uint32_t fold, double (*sum)[2]) {
    double acc[2][BOUND_CONT_FOLD][2] = {{{0.0}}};      /* [even, odd][row][lane] */
    for (uint32_t k = 0; k < n; k++, z += 2, R += 4, Q += 2) {
        const double zr = z[0], zi = z[1];
        z[0] = zr * R[0] + zi * R[2];
        z[1] = zr * R[1] + zi * R[3];
        for (uint32_t r = 0; r < fold; r++) {
            acc[k % 2][r][0] += Q[r * row] * z[0];
            acc[k % 2][r][1] += Q[r * row + 1] * z[1];
        }
    }
    for (uint32_t r = 0; r < fold; r++) {
        sum[r][0] = acc[0][r][0] + acc[1][r][0];
        sum[r][1] = acc[0][r][1] + acc[1][r][1];
    }
}
#endif

#if defined(BOUND_AVX2)
/* cont_rotate in four lanes where the CPU has AVX2 (BoundState.avx2): modes 2 t and 2 t + 1 side by side (lanes 0,
 * 1 the even mode's, lanes 2, 3 the odd one's: the even and odd sums of cont_row_sums), each lane the same IEEE
 * operations in the same order: the same bits; an odd count's last mode in lanes 0, 1 (lanes 2, 3 add 0 * 0 = +0,
 * which leaves a sum started at +0 as it is) */
BOUND_INLINE void quads_cont(double *restrict z, const double *restrict R, const double *restrict Q, size_t row,
                             uint32_t n, uint32_t fold, double (*sum)[2]) {
    const BoundQuad zero = {0.0, 0.0, 0.0, 0.0};
    BoundQuad acc[BOUND_CONT_FOLD];
    for (uint32_t r = 0; r < BOUND_CONT_FOLD; r++) acc[r] = zero;
    uint32_t k = 0;
    for (; k + 2 <= n; k += 2, z += 4, R += 8, Q += 4) {
        BoundQuad x, r0, r1, q;
        QUAD_LOAD(x, z);
        const BoundQuad zr = {x[0], x[0], x[2], x[2]}, zi = {x[1], x[1], x[3], x[3]};
        r0 = (BoundQuad){R[0], R[1], R[4], R[5]};
        r1 = (BoundQuad){R[2], R[3], R[6], R[7]};
        const BoundQuad e = zr * r0 + zi * r1;
        QUAD_STORE(z, e);
        for (uint32_t r = 0; r < fold; r++) {
            QUAD_LOAD(q, Q + r * row);
            acc[r] += q * e;
        }
    }
    if (k < n) {
        const double zr = z[0], zi = z[1];
        z[0] = zr * R[0] + zi * R[2];
        z[1] = zr * R[1] + zi * R[3];
        const BoundQuad e = {z[0], z[1], 0.0, 0.0};
        for (uint32_t r = 0; r < fold; r++) {
            const BoundQuad q = {Q[r * row], Q[r * row + 1], 0.0, 0.0};
            acc[r] += q * e;
        }
    }
    for (uint32_t r = 0; r < fold; r++) {
        sum[r][0] = acc[r][0] + acc[r][2];
        sum[r][1] = acc[r][1] + acc[r][3];
    }
}

/* quads_cont's two cases, each with its constant (fold 3: the check reads the velocity rows; 0) */
__attribute__((target("avx2"))) static void cont_quads(double *z, const double *R, const double *Q, size_t row,
                                                      uint32_t n, uint32_t fold, double (*sum)[2]) {
    if (!z || !R || !Q || !sum) return;
    if (fold == BOUND_CONT_FOLD) quads_cont(z, R, Q, row, n, BOUND_CONT_FOLD, sum);
    else quads_cont(z, R, Q, row, n, 0, sum);
}
#endif

/* the rounding error of s = a + b rounded: (a + b) - s exactly (two_sum, round to nearest, no fused operations) */
static double two_sum_error(double a, double b, double s) {
    const double bb = s - a;
    return (a - (s - bb)) + (b - bb);
}

/* the continued modes over a step of length h from t0 to tau = t0 + h rounded > t_end (rom_bound_step): E_M <- E_M
 * R_M where the state holds E_M at t0, fewer than BOUND_CONT_ANCHOR steps since its anchor, and the last step had
 * the length h; else anchored exactly at tau (cont_exact).  With `fold` (the error check read rows 0 to 2 since the
 * last step: it reads them after every step until it warns) their sums of the new E_M are formed here, while E is at
 * hand (cont_sum).  A function of the state and h alone (R_M of h, recomputed where cont_rh is another length): a
 * restored state continues with the same bits */
static void cont_step(BoundState *bs, const RomBoundModel *b, double t0, double h, double tau, int fold) {
    if (!bs || !b || !b->n_cont || !bs->cont_z) return;
    const uint32_t n = b->n_cont, rows = fold ? (b->rows < BOUND_CONT_FOLD ? b->rows : BOUND_CONT_FOLD) : 0u;
    const double *Q = b->cont + 2 * (size_t)n;                      /* row 0's amplitudes, rows 2 n apart */
    if (bs->cont_tau == t0 && bs->cont_n < BOUND_CONT_ANCHOR && h == bs->cont_h) {
        if (bs->cont_rh != h) {
            cont_exact(b, h, bs->cont_e);
            for (uint32_t k = 0; k < n; k++) {
                const double re = bs->cont_e[2 * (size_t)k], im = bs->cont_e[2 * (size_t)k + 1];
                double *R = bs->cont_r + 4 * (size_t)k;
                R[0] = re;
                R[1] = im;
                R[2] = -im;
                R[3] = re;
            }
            bs->cont_rh = h;
            bs->read_tau = NAN;                                     /* (cont_e lent as scratch) */
        }
        double *z = bs->cont_z;
        const double *R = bs->cont_r;
        const size_t row = 2 * (size_t)n;
        int quads = 0;
#if defined(BOUND_AVX2)
        quads = bs->avx2 && (rows == BOUND_CONT_FOLD || rows == 0);      /* four lanes: the same bits */
        if (quads) cont_quads(z, R, Q, row, n, rows, bs->cont_sum);
#endif
        if (!quads && rows == BOUND_CONT_FOLD) cont_rotate(z, R, Q, row, n, BOUND_CONT_FOLD, bs->cont_sum);
        else if (!quads) cont_rotate(z, R, Q, row, n, rows, bs->cont_sum);
        bs->cont_n += 1.0;
        bs->cont_drift += fabs(two_sum_error(t0, h, tau));
    } else {
        cont_exact(b, tau - table_end(b), bs->cont_z);
        for (uint32_t r = 0; r < rows; r++) cont_row_sums(Q + 2 * (size_t)n * r, bs->cont_z, n, bs->cont_sum[r]);
        bs->cont_n = bs->cont_drift = 0.0;
    }
    bs->cont_summed = rows > 0;
    bs->cont_tau = tau;
    bs->cont_h = h;
}

/* rom_bound_step's work once w holds its steps, m the shadow's inputs (a constant where the caller specializes) */
BOUND_INLINE void step_shadow(RomState *s, BoundState *bs, double h, size_t m) {
    const RomBoundModel *b = &s->model->bound;
    const size_t G = b->groups;
    double u[BOUND_MAX_INPUTS], du[BOUND_MAX_INPUTS];
    step_inputs(s, h, u, du);
    const BoundCache *c;
    if (h == bs->cache[0].h) {                          /* plane_maps' first hit, without the call */
        bs->cache[0].used = ++bs->clock;
        c = &bs->cache[0];
    } else {
        c = plane_maps(bs, b, h);
    }
    double u2 = 0.0, e2 = 0.0;
    for (size_t j = 0; j < m; j++) {    /* the weighted variations: the jump at the step's start, the slope over it */
        const double jump = fabs(u[j] - bs->u_prev[j]), slope = fabs(du[j]);
        for (size_t g = 0; g < G; g++) {
            double *V = &bs->V[j * G + g];
            const double v = c->decay[g] * (*V + jump) + c->slope[g] * slope;
            *V = v > 0 && v < BOUND_DECAY_FLOOR ? BOUND_DECAY_FLOOR : v;     /* (kept normal once positive) */
        }
        u2 += u[j] * u[j];
        e2 += (u[j] + du[j]) * (u[j] + du[j]);
    }
    /* |w| at the step's start: the last step's end computed it (else a reset or a restored state: now) */
    if (!bs->w_fresh) shadow_group(s, bs, 0);
    const double wn = bs->w_root, u_max = u2 > e2 ? u2 : e2;     /* (fmax: neither is NaN, the inputs are finite) */
    bs->w_int += h * c->growth * (wn + h * b->b_norm * sqrt(u_max));
    /* each plane in place (its two coordinates read before they are written); a held input (du = 0) skips the
     * slope's columns, whose products are exact zeros: the same sums */
    int held = 1;
    for (size_t j = 0; j < m; j++) held &= du[j] == 0.0;
    if (m == 1) {
        plane_step_one(bs, c, b, u[0], held ? 0.0 : du[0], held);     /* with group 0's sums of the new w */
    } else {
        double *w = bs->w;
        for (uint32_t p = 0; p < b->planes; p++) {
            const double *Phi = c->Phi + 4 * (size_t)p;
            const double w0 = w[2 * p], w1 = w[2 * p + 1];
            for (size_t i = 0; i < 2; i++) {
                double acc = Phi[i] * w0 + Phi[2 + i] * w1;
                const size_t r = (2 * p + i) * m;
                for (size_t j = 0; j < m; j++) {
                    acc += held ? c->G0[r + j] * u[j] : c->G0[r + j] * u[j] + c->G1[r + j] * du[j];
                }
                w[2 * p + i] = acc;
            }
        }
        groups_stale(bs);
    }
    for (size_t j = 0; j < m; j++) bs->u_prev[j] = u[j] + du[j];
    bs->steps += 1.0;
    const double tau = s->elapsed + h;                  /* the time since the start after this step (as rom.c's) */
    if (tau > table_end(b)) tail_decays(bs, b, tau, s->elapsed, c, h);
}

void rom_bound_step(RomState *s, double h) {
    BoundState *bs = s ? (BoundState *)s->bound : NULL;
    if (!bs) return;
    const RomBoundModel *b = &s->model->bound;
    if (bs->started == 0.0) {
        for (size_t i = 0; i < b->order; i++) bs->w[i] = s->initial_state_scale * b->w0[i];
        bs->started = 1.0;
    }
    if (b->inputs == 1) step_shadow(s, bs, h, 1);     /* the force f alone: the common case, specialized */
    else step_shadow(s, bs, h, b->inputs);
    /* the continued modes past the table (group 0 fresh: plane_step_one summed the rows the check read since the
     * last step: their sums too) */
    if (b->n_cont && s->elapsed + h > table_end(b)) {
        cont_step(bs, b, s->elapsed, h, s->elapsed + h, (int)(bs->groups[0] & 1u));
    }
}

/* what every row's bound shares at one time (tau since the start): the free response's table interval and
 * Hermite weights, or the tail's decays after the table; the shadow's |w| and the round-off allowance's factor.
 * Computed once for all the rows a caller reads at that time (rom_bound_exceeded: every velocity row) */
typedef struct {
    int in_table;              /* tau within the table */
    uint32_t k;                /* its interval */
    size_t block;              /* its error block */
    double c0, c1, c2, c3;     /* the cubic Hermite weights of g[k], g[k + 1], dg[k], dg[k + 1] (dg's times h) */
    double decay[BOUND_MAX_GROUPS];   /* after the table: exp(-alpha_g (tau - t_end)) */
    const double *cont;        /* after the table with SHCONT: the continued modes' E_M (cont_modes) */
    const double *cont_rows;   /* ... the rows' sums of their allowance (BoundState.cont_rows) */
    double cont_k0, cont_k1;   /* ... its factors (cont_modes) */
    const double (*cont_sum)[2];   /* ... rows 0 to 2's sums where the step formed them (cont_step), else NULL */
    double w_root;             /* |w| (started), else NaN: the rows compute s w0's */
    double steps_factor;       /* BOUND_ROUNDOFF + BOUND_ROUNDOFF_STEP n */
    double drift_growth;       /* >= exp(growth tau) (1 + x + x^2, x <= 1): the residual's drift, a Duhamel integral */
} RowTime;

/* the continued modes' E_M at tau > t_end for every row read then, the factors of their round-off allowance (the
 * derivation above cont_exact) and rows 0 to 2's sums where the step formed them: the state's, carried over the steps,
 * where it holds tau; else computed exactly (an anchor) into a scratch kept per time, the state left as it is (a
 * read never changes the continuation) */
static const double *cont_modes(BoundState *bs, const RomBoundModel *b, double tau, RowTime *rt) {
    rt->cont_k0 = rt->cont_k1 = 0.0;
    rt->cont_sum = NULL;
    rt->cont_rows = bs ? bs->cont_rows : NULL;
    if (!bs || !b || !b->n_cont || !bs->cont_z) return NULL;
    const double u = 0x1p-53;
    double n = 0.0, drift = 0.0;
    const double *E = bs->cont_z;
    if (bs->cont_tau == tau) {
        n = bs->cont_n;
        drift = bs->cont_drift;
        if (bs->cont_summed) rt->cont_sum = bs->cont_sum;
    } else {
        if (bs->read_tau != tau) {
            cont_exact(b, tau - table_end(b), bs->cont_e);
            bs->read_tau = tau;
        }
        E = bs->cont_e;
    }
    if (!((12.0 * n + 4.0 * bs->cont_amax * tau) * u + bs->cont_amax * drift <= 1e-3)) {
        rt->cont_k0 = rt->cont_k1 = INFINITY;             /* (|mu| tau ~ 1e12 rad: no bound) */
    } else {
        rt->cont_k0 = 1.01 * (BOUND_CONT_ROUNDOFF + ((double)b->n_cont + 8.0 + 12.0 * n) * u);
        rt->cont_k1 = 1.01 * (4.0 * u * tau + drift);
    }
    return E;
}

BOUND_INLINE void row_time(const RomState *s, RowTime *rt) {
    const RomBoundModel *b = &s->model->bound;
    BoundState *bs = (BoundState *)s->bound;
    const double tau = s->elapsed, t_end = table_end(b);
    rt->in_table = b->nodes && tau <= t_end;
    if (rt->in_table) {
        const double x = (tau > 0 ? tau : 0.0) / b->h_tab;
        uint32_t k = (uint32_t)x;                       /* floor: 0 <= x <= nodes - 1 (+ rounding) < 2^32 */
        if (k > b->nodes - 2) k = b->nodes - 2;
        const double t = x - (double)k, u = 1.0 - t;
        rt->k = k;
        rt->block = table_block(b, k);
        rt->c0 = (1.0 + 2.0 * t) * u * u;
        rt->c1 = t * t * (3.0 - 2.0 * t);
        rt->c2 = t * u * u;
        rt->c3 = t * t * (t - 1.0);
    } else {
        const double over = tau > t_end ? tau - t_end : 0.0;
        const int cached = tau == bs->tail_tau;          /* the step's decays (rom_bound_step), else computed */
        for (uint32_t g = 0; g < b->groups; g++) rt->decay[g] = cached ? bs->tail_decay[g] : floored_decay(b->rates[g] * over);
        rt->cont = b->n_cont ? cont_modes(bs, b, tau, rt) : NULL;
    }
    if (bs->started != 0.0) {
        if (!bs->w_fresh) shadow_group(s, bs, 0);
        rt->w_root = bs->w_root;
    } else {
        rt->w_root = NAN;
    }
    rt->steps_factor = BOUND_ROUNDOFF + BOUND_ROUNDOFF_STEP * bs->steps;
    rt->drift_growth = b->growth != 0.0 ? rom_growth_factor(b->growth, tau) : 1.0;     /* (its value at rate 0) */
}

/* the complement's free response of row r at the time of rt (per unit initial_state_scale): the table's Hermite
 * interpolation into *value and its certified error into *error; after the table the continued modes' sum (0
 * without SHCONT, or without a table) and the decaying tail of the others with the sum's round-off allowance
 * (harness/rom/bounds.py free_part) */
static inline void free_part(const RomBoundModel *b, const RowTime *rt, uint32_t r, double *value, double *error) {
    if (rt->in_table) {
        const uint32_t k = rt->k;
        const double *g = b->tab + (size_t)r * b->nodes, *dg = b->tab + (size_t)(b->rows + r) * b->nodes;
        *value = rt->c0 * g[k] + rt->c1 * g[k + 1] + b->h_tab * (rt->c2 * dg[k] + rt->c3 * dg[k + 1]);
        *error = b->terr[(size_t)r * b->blocks + rt->block];
        return;
    }
    const double *tail = b->row + (size_t)r * b->row_len + 1 + 2 * (size_t)b->inputs + (size_t)b->inputs * b->groups;
    double acc = 0.0;
    for (uint32_t g = 0; g < b->groups; g++) acc += tail[g] * rt->decay[g];
    double sum = 0.0, allow = 0.0;
    if (rt->cont) {                                     /* the continued modes (cont_modes) */
        double lanes[2];
        if (rt->cont_sum && r < BOUND_CONT_FOLD) {
            lanes[0] = rt->cont_sum[r][0];               /* formed in the step (cont_step): the same sums */
            lanes[1] = rt->cont_sum[r][1];
        } else {
            cont_row_sums(b->cont + 2 * (size_t)b->n_cont * (1 + (size_t)r), rt->cont, b->n_cont, lanes);
        }
        sum = lanes[0] - lanes[1];                      /* Re sum_M Q_rM E_M */
        allow = rt->cont_k0 * rt->cont_rows[2 * (size_t)r] + rt->cont_k1 * rt->cont_rows[2 * (size_t)r + 1];
    }
    *value = sum;
    *error = acc + allow;
}

/* the four slots' sums over the k coefficients (rows' coefficients col[i * stride + c], w[i]; group 0's:
 * group0_sums) */
static inline void group_sums(const double *col, size_t stride, const double *w, size_t k, double *out) {
    double a[4][BOUND_GROUP];                  /* [partial][slot] */
    for (size_t p = 0; p < 4; p++) {
        for (size_t c = 0; c < BOUND_GROUP; c++) a[p][c] = 0.0;
    }
    size_t i = 0;
    for (; i + 4 <= k; i += 4, col += 4 * stride) {
        for (size_t p = 0; p < 4; p++) {
            const double wi = w[i + p];
            const double *cp = col + p * stride;
            for (size_t c = 0; c < BOUND_GROUP; c++) a[p][c] += cp[c] * wi;
        }
    }
    for (size_t p = 0; i < k; i++, p++, col += stride) {               /* the last k mod 4 coefficients */
        for (size_t c = 0; c < BOUND_GROUP; c++) a[p][c] += col[c] * w[i];
    }
    for (size_t c = 0; c < BOUND_GROUP; c++) out[c] = (a[0][c] + a[1][c]) + (a[2][c] + a[3][c]);
}

/* group g of the rows' sums (slots 4 g to 4 g + 3: |w|^2 in slot 0, C w of row r in slot r + 1), kept until w
 * changes: an importer reads every output's bound at each step, each row once, and the error_tolerance check in
 * doStep needs only the velocity rows (group 0 with P <= 3).  Each sum is four partial sums side by side (the
 * coefficients i = 0, 1, 2, 3 mod 4, then (a0 + a1) + (a2 + a3)), the four slots side by side from the transposed
 * rows: none waits for another's last addition (one sum at a time waits for each of its own additions, the
 * latency of an addition per coefficient).  The same order whichever path asks for a sum (the step's |w|, a row
 * read or the check): the same numbers */
static void shadow_group(const RomState *s, BoundState *bs, size_t g) {
    const RomBoundModel *b = &s->model->bound;
    const size_t k = b->order, slots = row_slots(b);
    if (g == 0) {
        group0_sums(b, bs->w, bs->y);
        bs->w_root = sqrt(bs->y[0]);
        bs->w_fresh = 1;
    } else group_sums(bs->ct + BOUND_GROUP * g, slots, bs->w, k, bs->y + BOUND_GROUP * g);
    bs->groups[g / 64] |= (uint64_t)1 << (g % 64);
}

/* what the rows share at one time beside rt: the input at the last step's end and its size */
typedef struct {
    double up[BOUND_MAX_INPUTS], ua[BOUND_MAX_INPUTS];
} RowInputs;

/* (the shadow's row r, its certified error) at rt's time into *value, *cert; m the shadow's inputs, started and
 * channel whether w holds its steps and whether the model has a port channel (constants where a caller
 * specializes: rom_bound_exceeded) */
BOUND_INLINE void row_at(const RomState *s, const RowTime *rt, const RowInputs *in, uint32_t r, size_t m,
                        int started, int channel, double *value, double *cert) {
    const RomBoundModel *b = &s->model->bound;
    BoundState *bs = (BoundState *)s->bound;
    const size_t G = b->groups;
    const uint32_t P = s->model->n_probes;
    const double iss = s->initial_state_scale, scale = fabs(iss);
    const double *row = b->row + (size_t)r * b->row_len;
    double y, w_root;
    if (started) {
        const size_t g = ((size_t)r + 1) / BOUND_GROUP;
        if (!group_fresh(bs, g)) shadow_group(s, bs, g);
        if (g == 0) bs->rows_read = 1;
        y = bs->y[r + 1];
        w_root = rt->w_root;
    } else {                                            /* s w0 before the first step (s may still change) */
        const size_t k = b->order;
        const double *Cr = b->C + (size_t)r * k;
        double w2 = 0.0;
        y = 0.0;
        for (size_t q = 0; q < k; q++) {
            const double wq = iss * b->w0[q];
            y += Cr[q] * wq;
            w2 += wq * wq;
        }
        w_root = sqrt(w2);
    }
    double quasi = 0.0, trans = 0.0;
    for (size_t j = 0; j < m; j++) {
        y += row[1 + j] * in->up[j];                    /* the complement's quasi-static response */
        quasi += row[1 + m + j] * in->ua[j];
        for (size_t g = 0; g < G; g++) {
            const double H = row[1 + 2 * m + j * G + g], V = bs->V[j * G + g];
            if (V > 0) trans += H < 0 ? INFINITY : H * V;
        }
    }
    const double row_scale = r >= P && r < 3 * P ? b->e_scale : 1.0;     /* e rows of a parametric shadow */
    const double cn = row[0] * row_scale;
    double g_value, g_error;
    free_part(b, rt, r, &g_value, &g_error);
    y += iss * g_value;
    const double allow = cn * rt->steps_factor * (w_root + scale * b->x0_norm);
    double channel_cert = 0.0;              /* the port channel's part of the row and its own bound (rom_port.c) */
    *value = channel ? y + rom_channel_row(s, r, &channel_cert) : y;
    *cert = scale * g_error + quasi + trans + cn * b->e_norm * bs->w_int * rt->drift_growth + allow + channel_cert;
}

/* the inputs' terms the rows share (row_at) */
static void row_inputs(const RomState *s, RowInputs *in) {
    const BoundState *bs = (const BoundState *)s->bound;
    for (size_t j = 0; j < s->model->bound.inputs; j++) {
        in->up[j] = bs->u_prev[j];
        in->ua[j] = fabs(in->up[j]);
    }
}

/* (the shadow's row r, its certified error) at the state's time (rt: its row_time) */
static void shadow_row_at(const RomState *s, const RowTime *rt, uint32_t r, double *value, double *cert) {
    RowInputs in;
    row_inputs(s, &in);
    row_at(s, rt, &in, r, s->model->bound.inputs, ((const BoundState *)s->bound)->started != 0.0, s->channel != NULL,
           value, cert);
}

static void shadow_row(const RomState *s, uint32_t r, double *value, double *cert) {
    RowTime rt;
    row_time(s, &rt);
    shadow_row_at(s, &rt, r, value, cert);
}

/* the velocity bound of probe j (port: of port j) at rt's time, as rom_v_probe_error_bound (rom_v_port_error_bound)
 * gives it */
static double velocity_bound(const RomState *s, const RowTime *rt, uint32_t j, int port) {
    double y, cert;
    if (port) {
        shadow_row_at(s, rt, 3 * s->model->n_probes + j, &y, &cert);
        return fabs(rom_channel_port_velocity(s, j) - y) + cert;  /* the model's output, as rom.c rom_v_port */
    }
    shadow_row_at(s, rt, j, &y, &cert);
    /* the model's output, as rom.c rom_v_probe (the kind's, kept for the importer's read, and the port channel's) */
    return fabs(rom_v_probe_kept(s, j) - y) + cert;
}

double rom_v_probe_error_bound(const RomState *s, uint32_t j) {
    if (!s || !s->bound || j >= s->model->n_probes) return NAN;
    RowTime rt;
    row_time(s, &rt);
    return velocity_bound(s, &rt, j, 0);
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
    RowTime rt;
    row_time(s, &rt);
    return velocity_bound(s, &rt, j, 1);
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

/* the error check over the velocity rows of the probes (port: of the ports) j < n: 1 (and the message) at the first
 * bound above error_tolerance, else 0; m, started, channel as row_at's (constants where rom_bound_exceeded
 * specializes) */
BOUND_INLINE int rows_exceed(const RomState *s, const RowTime *rt, const RowInputs *in, int port, uint32_t n,
                             size_t m, int started, int channel, char *message, size_t message_size) {
    const uint32_t P = s->model->n_probes;
    for (uint32_t j = 0; j < n; j++) {
        double y, cert;
        row_at(s, rt, in, port ? 3 * P + j : j, m, started, channel, &y, &cert);
        /* the model's output as rom.c gives it (rom_v_port; rom_v_probe: the kind's, kept for the importer's read,
         * and the port channel's): velocity_bound's sum */
        const double v = port ? rom_channel_port_velocity(s, j) : rom_v_probe_kept(s, j);
        const double bound = fabs(v - y) + cert;
        if (!(bound <= s->error_tolerance)) {
            if (message && message_size) {
                const int written = snprintf(message, message_size, "%s_%u's certified error bound %.3g m s^-1 "
                                             "exceeds error_tolerance = %.3g m s^-1 at t = %.9g s",
                                             port ? "v_port" : "v_probe", j + 1, bound, s->error_tolerance, s->time);
                const RomBoundModel *b = &s->model->bound;
                double g_value, g_error;
                free_part(b, rt, port ? 3 * P + j : j, &g_value, &g_error);
                const double free_share = fabs(s->initial_state_scale) * g_error;
                /* past the table the modes of the complement's free response that are not continued (SHCONT: those
                 * left out as too small to matter, the defective ones, the planes never computed) are bounded by
                 * their size alone (an undamped bar's does not decay): say so where that is most of the bound, so
                 * that a warning on an accurate model reads as what it is */
                if (b->nodes && !rt->in_table && free_share >= 0.5 * bound && written > 0 &&
                    (size_t)written < message_size) {
                    snprintf(message + written, message_size - (size_t)written, ", %.3g m s^-1 of it the "
                             "complement's free response from the initial state past the end of its table "
                             "(t > %.9g s): %u modes continued exactly, the others bounded by their size, not by the "
                             "model's error", free_share, table_end(b), b->n_cont);
                }
            }
            return 1;
        }
    }
    return 0;
}

/* The error check's common case (the probes' velocity rows of a one-input shadow whose w holds its steps, no port
 * channel, no ports) within the free response table: every velocity row after every step until the warning.  Four
 * rows side by side (lane l of quad q: row 4 q + l) at row_time's interval, weights and decays (computed once for
 * the quads), each lane row_at's and rows_exceed's scalar IEEE operations in their order (the same bits, the same
 * answer), from the rows' terms laid out by lanes once per version
 * of the model's rows (check_terms: |c_r|, D_r, the static gain, |c_r| |E|, the transient gains with a negative one
 * (unbounded) as +inf, which is what row_at adds for it where V_g > 0; the rows' offsets in the table), each V_g > 0
 * (row_at's test) once for all the rows; past the table where no mode is continued (SHCONT absent), the same with
 * free_part's tail sum over the groups' decays (the rows' tails laid out beside the gains).  -DROM_NO_LANES, past the
 * table with continued modes, or other models: rows_exceed. */
#if defined(BOUND_LANES)
static void check_terms(BoundState *bs, const RomBoundModel *b, uint32_t P) {
    if (!bs || !b || !bs->chk || P > BOUND_CHECK_ROWS) return;
    const size_t G = b->groups, L = BOUND_CHECK_LANES, width = (4 + 2 * G) * L;
    for (uint32_t r = 0; r < (P + L - 1) / L * L; r++) {
        double *t = bs->chk + r / L * width + r % L;
        const double *row = b->row + (size_t)r * b->row_len;
        const int real = r < P;
        const size_t read = real ? r : P - 1;
        bs->chk_tab[r] = read * b->nodes;
        bs->chk_err[r] = read * b->blocks;
        t[0] = real ? row[0] * 1.0 : 0.0;               /* cn: row_at's row scale of a velocity row, 1 */
        t[L] = real ? row[1] : 0.0;
        t[2 * L] = real ? row[2] : 0.0;
        t[3 * L] = real ? t[0] * b->e_norm : 0.0;
        for (size_t g = 0; g < G; g++) t[(4 + g) * L] = real ? (row[3 + g] < 0 ? INFINITY : row[3 + g]) : 0.0;
        for (size_t g = 0; g < G; g++) t[(4 + G + g) * L] = real ? row[3 + G + g] : 0.0;      /* free_part's tail */
    }
    bs->chk_gen = b->generation;
}

typedef double BoundRows __attribute__((vector_size(32)));      /* four rows (an AVX register, or two SSE2 ones) */
typedef int64_t BoundRowBits __attribute__((vector_size(32)));
#define ROWS_LOAD(v, p) memcpy(&(v), (p), sizeof(BoundRows))
#define ROWS_SPLAT(x) ((BoundRows){(x), (x), (x), (x)})
#define ROWS_GATHER(p, o) ((BoundRows){(p)[(o)[0]], (p)[(o)[1]], (p)[(o)[2]], (p)[(o)[3]]})

/* 1 where the velocity bound of a probe of quad q (probes 4 q to 4 q + 3) is above error_tolerance, else 0
 * (table_rows_exceed: within the table, check_terms current, the rows' groups of sums and |w| fresh; vs the model's
 * outputs by quads).  One quad a call: what the lanes share is in registers, not spilled over a loop */
BOUND_INLINE int table_quad_body(const RomState *s, const BoundState *bs, const double *vs, uint32_t q,
                                 const RowTime *rt, int past) {
    const RomBoundModel *b = &s->model->bound;
    const double iss = s->initial_state_scale, scale = fabs(iss), up = bs->u_prev[0], tol = s->error_tolerance;
    const BoundRows zero = ROWS_SPLAT(0.0), ups = ROWS_SPLAT(up), ua = ROWS_SPLAT(fabs(up)), is = ROWS_SPLAT(iss),
                    sc = ROWS_SPLAT(scale), sf = ROWS_SPLAT(rt->steps_factor),
                    wp = ROWS_SPLAT(rt->w_root + scale * b->x0_norm), wd = ROWS_SPLAT(bs->w_int),
                    dr = ROWS_SPLAT(rt->drift_growth);
    const BoundRowBits magnitude = {INT64_MAX, INT64_MAX, INT64_MAX, INT64_MAX};
    const uint32_t P = s->model->n_probes, L = BOUND_CHECK_LANES;
    const size_t G = b->groups;
    const double *T = bs->chk + q * (4 + 2 * G) * L;
    BoundRows y, v, cn, D, S, cne, H, g_value, g_error;
    ROWS_LOAD(y, bs->y + 1 + q * L);                /* slots 4 q + 1 to 4 q + 4 (y has four slots' slack) */
    if (!past) {
        /* free_part's table at row_time's interval and weights: row r's nodes k, k + 1 at gk + r nodes */
        const BoundRows c0 = ROWS_SPLAT(rt->c0), c1 = ROWS_SPLAT(rt->c1), c2 = ROWS_SPLAT(rt->c2),
                        c3 = ROWS_SPLAT(rt->c3), ht = ROWS_SPLAT(b->h_tab);
        const double *gk = b->tab + rt->k, *dk = gk + (size_t)b->rows * b->nodes, *te = b->terr + rt->block;
        const size_t *og = bs->chk_tab + q * L, *oe = bs->chk_err + q * L;
        g_value = c0 * ROWS_GATHER(gk, og) + c1 * ROWS_GATHER(gk + 1, og) +
                  ht * (c2 * ROWS_GATHER(dk, og) + c3 * ROWS_GATHER(dk + 1, og));
        g_error = ROWS_GATHER(te, oe);
    } else {
        /* past the table without continued modes: free_part's tail sum over row_time's decays (value 0, allowance
         * 0) */
        BoundRows acc = zero, tail;
        for (size_t g = 0; g < G; g++) {
            ROWS_LOAD(tail, T + (4 + G + g) * L);
            acc += tail * ROWS_SPLAT(rt->decay[g]);
        }
        g_value = zero;
        g_error = acc + zero;
    }
    ROWS_LOAD(v, vs + q * L);
    ROWS_LOAD(cn, T);
    ROWS_LOAD(D, T + L);
    ROWS_LOAD(S, T + 2 * L);
    ROWS_LOAD(cne, T + 3 * L);
    y += D * ups;                                   /* row_at's sums, in its order */
    const BoundRows quasi = zero + S * ua;
    BoundRows trans = zero;
    for (size_t g = 0; g < G; g++) {
        const double Vg = bs->V[g];
        if (Vg > 0) {                               /* (row_at's test) */
            ROWS_LOAD(H, T + (4 + g) * L);
            trans += H * ROWS_SPLAT(Vg);
        }
    }
    y += is * g_value;
    const BoundRows allow = cn * sf * wp;
    const BoundRows cert = sc * g_error + quasi + trans + cne * wd * dr + allow + zero;
    const BoundRows bound = (BoundRows)((BoundRowBits)(v - y) & magnitude) + cert;    /* fabs(v - y) + cert */
    const uint32_t n = P - q * L < L ? P - q * L : L;
    for (uint32_t l = 0; l < n; l++) {
        if (!(bound[l] <= tol)) return 1;
    }
    return 0;
}

#if defined(BOUND_AVX2)
__attribute__((target("avx2"))) static int table_quad_avx2(const RomState *s, const BoundState *bs,
                                                          const double *vs, uint32_t q, const RowTime *rt) {
    if (!s || !bs || !vs || !rt) return 0;
    return rt->in_table ? table_quad_body(s, bs, vs, q, rt, 0) : table_quad_body(s, bs, vs, q, rt, 1);
}
#endif

BOUND_APART int table_quad(const RomState *s, const BoundState *bs, const double *vs, uint32_t q,
                           const RowTime *rt) {
    if (!s || !bs || !vs || !rt) return 0;
    return rt->in_table ? table_quad_body(s, bs, vs, q, rt, 0) : table_quad_body(s, bs, vs, q, rt, 1);
}

/* table_quad over the probes' quads, in four AVX2 lanes where the CPU has AVX2 (the same bits) */
static int table_lanes(const RomState *s, const BoundState *bs, const double *vs, const RowTime *rt) {
    if (!s || !bs || !vs || !rt) return 0;
    for (uint32_t q = 0; q * BOUND_CHECK_LANES < s->model->n_probes; q++) {
#if defined(BOUND_AVX2)
        if (bs->avx2) {
            if (table_quad_avx2(s, bs, vs, q, rt)) return 1;
            continue;
        }
#endif
        if (table_quad(s, bs, vs, q, rt)) return 1;
    }
    return 0;
}
#endif

/* rows_exceed of the probes' velocity rows (the common case: one input, stepped, no channel) */
BOUND_APART int probe_rows_exceed(const RomState *s, char *message, size_t message_size) {
    if (!s || !s->bound) return 0;
    RowTime rt;
    row_time(s, &rt);
    RowInputs in;
    row_inputs(s, &in);
    return rows_exceed(s, &rt, &in, 0, s->model->n_probes, 1, 1, 0, message, message_size);
}

/* the error check of the probes' velocity rows within the table (the common case above): 1 (and rows_exceed's
 * message: the same rows, asked again, the same bits) at the first bound above error_tolerance, else 0 */
BOUND_APART int table_rows_exceed(const RomState *s, char *message, size_t message_size) {
    if (!s || !s->bound) return 0;
#if defined(BOUND_LANES)
    const uint32_t P = s->model->n_probes;
    const RomBoundModel *b = &s->model->bound;
    BoundState *bs = (BoundState *)s->bound;
    if (P == 0) return 0;
    for (size_t g = 0; g <= (size_t)P / BOUND_GROUP; g++) {          /* rows 0 to P - 1: slots 1 to P; |w| */
        if (!group_fresh(bs, g)) shadow_group(s, bs, g);
    }
    if (!bs->w_fresh) shadow_group(s, bs, 0);           /* (row_time's) */
    bs->rows_read = 1;                                  /* group 0's rows (row_at): the next step sums them */
    if (bs->chk_gen != b->generation) check_terms(bs, b, P);
    if (bs->chk_gen != b->generation) return probe_rows_exceed(s, message, message_size);     /* (never: P <= 100) */
    /* the model's outputs as rows_exceed reads them (rom_v_probe_kept: here once per step, the importer reads them
     * kept), by quads (the last one's lanes past P: 0, not checked) */
    double vs[BOUND_CHECK_ROWS];
    if (s->v_kept && !s->channel) {                     /* rom_v_probe_kept without a channel, its loads hoisted */
        double *kept = s->v_kept;
        double (*const v_probe)(const RomState *, uint32_t) = s->model->ops->v_probe;
        for (uint32_t j = 0; j < P; j++) {
            double v = kept[j];
            if (isnan(v)) kept[j] = v = v_probe(s, j);
            vs[j] = v;
        }
    } else {
        for (uint32_t j = 0; j < P; j++) vs[j] = rom_v_probe_kept(s, j);
    }
    for (uint32_t j = P; j % BOUND_CHECK_LANES; j++) vs[j] = 0.0;
    RowTime rt;                                         /* (the interval, weights, decays every quad reads) */
    row_time(s, &rt);
    if (!table_lanes(s, bs, vs, &rt)) return 0;
#endif
    return probe_rows_exceed(s, message, message_size);
}

/* rom_bound_exceeded's other cases: ports, a port channel, several inputs, before the first step */
BOUND_APART int all_rows_exceed(const RomState *s, char *message, size_t message_size) {
    if (!s || !s->bound) return 0;
    RowTime rt;                                          /* one time and one input for every velocity row */
    row_time(s, &rt);
    RowInputs in;
    row_inputs(s, &in);
    const uint32_t P = s->model->n_probes, ports = s->model->n_ports;
    const size_t m = s->model->bound.inputs;
    const int started = ((const BoundState *)s->bound)->started != 0.0, channel = s->channel != NULL;
    return rows_exceed(s, &rt, &in, 0, P, m, started, channel, message, message_size) ||
           rows_exceed(s, &rt, &in, 1, ports, m, started, channel, message, message_size);
}

int rom_bound_exceeded(const RomState *s, char *message, size_t message_size) {
    if (!s || !s->bound || !(s->error_tolerance > 0)) return 0;
    const RomBoundModel *b = &s->model->bound;
    const int started = ((const BoundState *)s->bound)->started != 0.0;
    if (b->inputs == 1 && started && !s->channel && s->model->n_ports == 0) {    /* f alone, stepped, no ports */
        if (b->nodes && (s->elapsed <= table_end(b) || !b->n_cont)) return table_rows_exceed(s, message, message_size);
        return probe_rows_exceed(s, message, message_size);
    }
    return all_rows_exceed(s, message, message_size);
}

/* the serialized shadow: w, V, u_prev, w_int, steps, started, the tails' decays after the table (tail_tau,
 * tail_decay[groups]: chained over the steps, tail_decays), then with SHCONT the continued modes' E_M (Re, Im),
 * cont_tau, cont_n, cont_h, cont_drift (carried over the steps, cont_step): a restored state continues with the same
 * bits */
static size_t cont_state_doubles(const RomBoundModel *b) {
    return b->n_cont ? 2 * (size_t)b->n_cont + 4 : 0;
}

size_t rom_bound_state_doubles(const RomModel *m) {
    const RomBoundModel *b = &m->bound;
    return b->order ? b->order + (size_t)b->inputs * (b->groups + 1) + 3 + 1 + b->groups + cont_state_doubles(b) : 0;
}

/* a restored tails' chain (serialized: tail_tau, -1 for none, tail_decay): a time after the table's end and decays
 * in [0, 2] (tail_decays' chain, rounded up from at most 1); else none (computed exactly at the next step).  Kept
 * where a parametric shadow is assembled at the state's c, d next (rom_bound_assemble): the state's own rates */
static void tails_restored(BoundState *bs, const RomBoundModel *b) {
    int valid = bs->tail_tau > table_end(b);
    for (uint32_t g = 0; valid && g < b->groups; g++) valid = bs->tail_decay[g] >= 0 && bs->tail_decay[g] <= 2.0;
    if (!valid) bs->tail_tau = NAN;
    bs->tails_restored = valid;
}

/* a restored continuation (cont_step): at a time after the table's end, a step count from 0 to BOUND_CONT_ANCHOR, a
 * step length > 0, and each E_M within twice its allowance's relative error (cont_exact's derivation: eps_n +
 * eps_0, the exact value's own) of the exact value at cont_tau; else none (anchored exactly at the next step) */
static void cont_restored(BoundState *bs, const RomBoundModel *b) {
    const double tau = bs->cont_tau, n = bs->cont_n, drift = bs->cont_drift, u = 0x1p-53;
    int valid = isfinite(tau) && tau > table_end(b) && whole(n, 0, BOUND_CONT_ANCHOR) && isfinite(bs->cont_h) &&
                bs->cont_h > 0 && drift >= 0 && drift <= n * u * tau;
    if (valid) cont_exact(b, tau - table_end(b), bs->cont_e);
    for (uint32_t k = 0; valid && k < b->n_cont; k++) {
        const double a = fabs(b->cont[2 * (size_t)k]) + fabs(b->cont[2 * (size_t)k + 1]);
        const double *z = bs->cont_z + 2 * (size_t)k, *e = bs->cont_e + 2 * (size_t)k;
        const double rel = 2.0 * 1.002 * (u * (6.0 + 12.0 * n + 8.0 * a * tau) + a * drift);
        valid = fabs(z[0] - e[0]) + fabs(z[1] - e[1]) <= rel * (fabs(e[0]) + fabs(e[1])) + 4.0 * u;   /* NaN: not */
    }
    bs->read_tau = NAN;
    bs->cont_summed = 0;                                /* (rows 0 to 2's sums: formed again from E when read) */
    if (!valid) {
        bs->cont_tau = NAN;
        bs->cont_n = bs->cont_h = bs->cont_drift = 0.0;
    }
}

unsigned char *rom_bound_state_put(const RomState *s, unsigned char *cursor) {
    const BoundState *bs = (const BoundState *)s->bound;
    if (!bs) return cursor;
    const RomBoundModel *b = &s->model->bound;
    cursor = rom_put_f64s(cursor, bs->w, b->order);
    cursor = rom_put_f64s(cursor, bs->V, (size_t)b->inputs * b->groups);
    cursor = rom_put_f64s(cursor, bs->u_prev, b->inputs);
    const double scalars[3] = {bs->w_int, bs->steps, bs->started};
    cursor = rom_put_f64s(cursor, scalars, 3);
    const double tail_tau = isfinite(bs->tail_tau) ? bs->tail_tau : -1.0;     /* (a state's values are finite) */
    cursor = rom_put_f64s(cursor, &tail_tau, 1);
    cursor = rom_put_f64s(cursor, bs->tail_decay, b->groups);
    if (!cont_state_doubles(b)) return cursor;
    cursor = rom_put_f64s(cursor, bs->cont_z, 2 * (size_t)b->n_cont);
    const double cont[4] = {isfinite(bs->cont_tau) ? bs->cont_tau : -1.0, bs->cont_n, bs->cont_h, bs->cont_drift};
    return rom_put_f64s(cursor, cont, 4);
}

const unsigned char *rom_bound_state_get(RomState *s, const unsigned char *cursor) {
    BoundState *bs = (BoundState *)s->bound;
    if (!bs) return cursor;
    const RomBoundModel *b = &s->model->bound;
    cursor = rom_get_f64s(cursor, bs->w, b->order);
    groups_stale(bs);
    cursor = rom_get_f64s(cursor, bs->V, (size_t)b->inputs * b->groups);
    cursor = rom_get_f64s(cursor, bs->u_prev, b->inputs);
    double scalars[3];
    cursor = rom_get_f64s(cursor, scalars, 3);
    bs->w_int = scalars[0];
    bs->steps = scalars[1];
    bs->started = scalars[2] != 0.0 ? 1.0 : 0.0;
    for (size_t i = 0; i < (size_t)b->inputs * b->groups; i++) {
        if (!(bs->V[i] >= 0)) bs->V[i] = INFINITY;       /* a damaged variation: no bound, visibly */
    }
    cursor = rom_get_f64s(cursor, &bs->tail_tau, 1);
    cursor = rom_get_f64s(cursor, bs->tail_decay, b->groups);
    tails_restored(bs, b);
    if (!cont_state_doubles(b)) return cursor;
    cursor = rom_get_f64s(cursor, bs->cont_z, 2 * (size_t)b->n_cont);
    double cont[4];
    cursor = rom_get_f64s(cursor, cont, 4);
    bs->cont_tau = cont[0];
    bs->cont_n = cont[1];
    bs->cont_h = cont[2];
    bs->cont_drift = cont[3];
    cont_restored(bs, b);
    return cursor;
}
