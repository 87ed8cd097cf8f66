/*
 * sphrom full SPH step in C: the right-hand sides of the paper's eqs. 2.10-2.11
 * in the total Lagrangian frame (particles fixed at their reference positions,
 * precomputed periodic neighbour lists and weights (m_j/rho_j(0)) grad W_ij,
 * harness/sph/operator.py) and the explicit (and symplectic) Euler step.
 *
 * The arithmetic repeats harness/sph/loops.py (rates, advance with
 * method 0 or 1) operation for operation, so the two agree bit for bit
 * (-ffp-contract=off; tests/test_fmu_c.py checks it).  Used for the
 * same-language benchmark (C frozen reduced step against C full SPH step); it
 * is its own library (libsphrom_sph, with rom_fail.c for its messages), in
 * neither the FMU binaries nor the core library.  No FMI types, no globals.
 *
 * Fields of length 1 carry a uniform value (flag bits SPH_UNIFORM_*), as in
 * the compiled loops of harness/sph/loops.py.  Units: v [m s^-1],
 * rho [kg m^-3], c [m^2 s^-2 ... as the scene defines it], d [s^-1], force per mass g [m s^-2].
 */
#ifndef SPHROM_SPH_H
#define SPHROM_SPH_H

#include <stddef.h>
#include <stdint.h>

#include "rom.h"      /* ROM_API, RomStatus, rom_fail */

#ifdef __cplusplus
extern "C" {
#endif

/* flag bits, as harness/sph/loops.py */
#define SPH_DAMPING 1u
#define SPH_FORCE 2u
#define SPH_UNIFORM_C 4u
#define SPH_UNIFORM_RHO0 8u
#define SPH_UNIFORM_D 16u
#define SPH_UNIFORM_PROFILE 32u
#define SPH_STENCIL 64u            /* layout: index holds k offsets, weight is [k][n] (see SphOperator) */
#define SPH_METHOD_EULER 0
#define SPH_METHOD_SYMPLECTIC 1

/* The operator of eq. 2.9 in one of two layouts.  Neighbour lists: index [n][k] (neighbour j of particle i),
 * weight [n][k].  Fixed offsets (flag SPH_STENCIL, every row's neighbours at the same offsets, as
 * harness/sph/operator.py detects): index [k] the offsets o_m in (-n, n), neighbour j = (i + o_m) mod n, and
 * weight [k][n] the weights by offset, contiguous in i.  Both give the same bits. */
typedef struct {
    int64_t n, k;              /* particles, neighbours per particle */
    const int64_t *index;      /* [n][k] neighbour j of particle i, or [k] offsets (SPH_STENCIL) */
    const double *weight;      /* [n][k] (m_j/rho_j(0)) grad W(x_i - x_j), 0 where padded; [k][n] (SPH_STENCIL) */
    const double *rho0, *c, *d, *profile;   /* [n], or [1] when uniform (flags) */
    uint32_t flags;
} SphOperator;

/* Checks sizes, pointers, flags, every neighbour index or offset, and every weight (O(n k)). */
ROM_API RomStatus sph_check(const SphOperator *op, char *message, size_t message_size);

/* dv, drho = the rates of eqs. 2.11, 2.10 at (v, rho) with force history value g; p: [n] scratch */
ROM_API RomStatus sph_rates(const SphOperator *op, const double *v, const double *rho, double g, double *dv,
                            double *drho, double *p, char *message, size_t message_size);

/* n_steps steps of length dt in place (method 0 explicit Euler, 1 symplectic Euler: rho then v),
 * with g[s] the force value of step s (NULL: 0).  work: [3 n].  Fails (message names the step,
 * *done the steps completed) when v or rho stops being finite or rho <= 0; the check runs every
 * check_every steps and after the last (as loops.advance). */
ROM_API RomStatus sph_advance(const SphOperator *op, int method, double *v, double *rho, int64_t n_steps, double dt,
                              const double *g, double *work, int64_t check_every, int64_t *done, char *message,
                              size_t message_size);

/* Flat-argument form of sph_advance for ctypes (builds the SphOperator and checks it) */
ROM_API RomStatus sph_advance_flat(int64_t n, int64_t k, const int64_t *index, const double *weight,
                                   const double *rho0, const double *c, const double *d, const double *profile,
                                   uint32_t flags, int method, double *v, double *rho, int64_t n_steps, double dt,
                                   const double *g, double *work, int64_t check_every, int64_t *done, char *message,
                                   size_t message_size);

#ifdef __cplusplus
}
#endif

#endif /* SPHROM_SPH_H */
