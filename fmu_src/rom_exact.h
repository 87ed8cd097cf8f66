/*
 * Model kind 2, the exact linear reduced model in the specific volume
 * (harness/rom/exact_linear.py), the path of every linear model (the balanced
 * one too): its own data behind RomModel.body and RomState.body (private to
 * the core and its C test driver; rom_exact.c owns them, the rest of the core
 * reaches them through the kind's operations, rom_exact_kind()).
 *
 * The state z = (a; b) has k = k_v + k_rho coordinates (k_rho = k_e, the
 * specific-volume coordinates); a lives in RomState.av, b in RomState.ar.
 * Arrays are kept as the resources store them (row-major).
 */
#ifndef SPHROM_ROM_EXACT_H
#define SPHROM_ROM_EXACT_H

#include "rom_internal.h"

#define ROM_EXACT_CACHE 2            /* exponentials kept per state (two step lengths) */

typedef struct {
    uint32_t k;                /* k_v + k_rho: the length of z */
    double *z0;                /* [k] initial reduced state (a; b) */
    double *A;                 /* [k][k] row-major: dz/dt = A z + B f */
    double *B;                 /* [k] input column, NULL without input */
    double *Q, *S;             /* [k][k] real Schur form A = Q S Q^T (skew A), NULL otherwise */
    double *y0;                /* [k] Q^T z0 (with the Schur form) */
    double *Pv;                /* [n_probes][k] v rows over z (rom.h's format: a file without output rows is
                                * stored the same way, zero over the block it skips) */
    double *Pe;                /* [n_probes][2][k] e rows over z at the probe's two particles */
    double *pw, *prho0;        /* [n_probes][2] interpolation weights, rho0 at those particles */
    double *probe_x;           /* [n_probes] probe positions in units of L (RomModel.probe_x) */
    int blocks;                /* 1: A block diagonal (flag blocks): stepped block by block, O(k) per step (a
                                * skew one's 2 x 2 blocks: rotations by w h from cos and sin) */
    int damping;               /* 0: a skew A (flag damping clear) */
    int free_path;             /* 1: the Schur form (a dense skew A): the free response evaluated at t */
    void *storage_;            /* one allocation behind the arrays */
} RomExactModel;

/* One cached exponential: the maps of a step of length h */
typedef struct {
    double h;                  /* step length [s]; 0 when the slot is empty */
    int64_t used;              /* clock of the last use (least recently used is replaced) */
    double *Phi;               /* [k][k] e^{A h} */
    double *G0, *G1;           /* [k][inputs] held-input and linear-input columns */
} RomExpCache;

typedef struct {
    double *X;                 /* [k] the forced part of z (the whole z without the Schur form) */
    double *work;              /* scratch for the exponential: 4 (k + 2 inputs)^2 + 2k */
    RomExpCache cache[ROM_EXACT_CACHE];
    int64_t clock;             /* cache clock */
    int64_t n_expm;            /* exponentials computed since the state was created */
    void *storage_;            /* one allocation behind the arrays */
} RomExactState;

#endif /* SPHROM_ROM_EXACT_H */
