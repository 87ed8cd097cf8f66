/*
 * Model kind 1, the frozen-coefficient reduced model (eqs. 2.19-2.24): its own
 * data behind RomModel.body and RomState.body (private to the core and its C
 * test driver; rom_frozen.c owns them, the rest of the core reaches them
 * through the kind's operations, rom_frozen_kind()).
 *
 * Matrices are kept transposed and zero-padded (k_v, k_rho rounded up to
 * multiples of 4: RomModel.kv_pad, kr_pad) so that the inner loops run over
 * contiguous, fixed-width blocks; the arithmetic on every real entry is the
 * file's, in the same order.
 */
#ifndef SPHROM_ROM_FROZEN_H
#define SPHROM_ROM_FROZEN_H

#include "rom_internal.h"

typedef struct {
    /* the kind's own header (rom_layout.h ROM_FROZEN_HEAD_*) */
    uint32_t integrator;       /* ROM_INTEGRATOR_EULER or ROM_INTEGRATOR_SYMPLECTIC */
    uint32_t n_pairs;          /* k_rho (k_rho + 1)/2, or 0 without the tensor (the particle refresh) */
    uint32_t n_freeze_default; /* the parameter n_freeze's start value */
    double dt;                 /* the internal step of the scene [s], the parameter dt's start value */
    uint32_t nm;               /* length of a padded M^T block: k_v kr_pad rounded up to 32 */
    double *a_v0, *a_rho0;     /* initial reduced coordinates [k_v], [k_rho] */
    double *Kt;                /* K^T: Kt[q*kv_pad + p] = K[p][q] (eq. 2.21 projected) */
    double *b;                 /* [kv_pad] eq. 2.22 projected */
    double *Dt;                /* D^T [k_v][kv_pad] (eq. 2.24 projected), NULL without damping */
    double *p;                 /* [kv_pad] input row U^vT profile, NULL without input */
    double *Tt;                /* the refresh tensor T[k][p][q] as entries i = q*kr_pad + p of M^T, in blocks
                                * of 32 with each block's pairs contiguous: Tt[(i/32)*n_pairs*32 + k*32 + i%32] */
    double *W;                 /* the symmetric refresh (T symmetric in (a, b, p) bit for bit, rom_frozen.c
                                * frozen_symmetric): one row of k_v (stride kv_quad, zero-padded) per sorted
                                * index triple, T[(a,b)][p] = w_ab W[{a, b, p}]; NULL
                                * when T is not symmetric */
    uint32_t *sym_off;         /* [n_pairs][k_rho]: offset in W of pair k's row p */
    double *pair_scale;        /* [n_pairs] w_ab: 1 (a = b) or 2 */
    uint32_t kv_quad;          /* k_v rounded up to 4: W's row stride */
    int symmetric;             /* 1: the refresh reads W (chosen at load by measured cost; same bits as Tt's) */
    int keep_skip;             /* 1 (the default): a refresh of unchanged inputs is skipped (rom_frozen_set_refresh) */
    const double *Ur;          /* the particle refresh (sections PARTUR, PARTGUV, PARTIR0; decided at packaging where
                                * it costs less than the tensor): U^rho [N][k_rho], G U^v [N][k_v], 1/rho0 [N] */
    const double *GUv;
    const double *inv_rho0;
    uint32_t n_particles;      /* N (0 without the sections) */
    int particles;             /* 1: M from the particles (rom_frozen.c refresh_particles), the default with them */
    double *Pv, *Prho;         /* probe rows [n_probes][k_v], [n_probes][k_rho] */
    double *probe_x;           /* [n_probes] probe positions in units of L (RomModel.probe_x) */
    void *storage_;            /* one allocation behind the arrays */
} RomFrozenModel;

typedef struct {
    double dt;                 /* internal step [s] (parameter) */
    int32_t n_freeze;          /* refresh period (parameter) */
    double *Mt;                /* M(a^rho)^T: Mt[q*kr_pad + p] = M[p][q], [nm] */
    double *F;                 /* the force term p f (and the ports') [kv_pad] */
    double *dv, *dr;           /* scratch: rates [kv_pad], [kr_pad] */
    double *S;                 /* scratch: a^rho_a a^rho_b per pair [n_pairs] */
    double *Ms;                /* scratch of the symmetric refresh: M [k_rho][kv_quad] (NULL without W) */
    double *last_in;           /* the inputs of the last refresh: a^rho [k_rho], f, the port inputs u_j */
    int refreshed;             /* M^T and F hold the refresh of last_in (0 after a reset or a state set) */
    void *storage_;            /* one allocation behind the arrays */
} RomFrozenState;

#endif /* SPHROM_ROM_FROZEN_H */
