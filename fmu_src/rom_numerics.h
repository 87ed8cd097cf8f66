/*
 * The dense numerics the model kinds and the error bounds share (rom_numerics.c): the matrix exponential, and the
 * growth factor of the truth's e^{At} (the shadow's and the port channel's drifts).
 * It calls nothing of the core (rom_internal.h's inline helpers aside), so that every file that needs it
 * (rom_exact.c, rom_bound.c) sits above it in the call graph (rom_internal.h draws it; no circle).
 */
#ifndef SPHROM_ROM_NUMERICS_H
#define SPHROM_ROM_NUMERICS_H

#include "rom_internal.h"

/* E = e^M (n x n, row-major) by scaling and squaring with a Taylor polynomial; X, T: n x n scratch.
 * Returns 1 when E is finite, 0 when M or the result is not finite, n is 0 or a pointer is NULL. */
int rom_expm_taylor(size_t n, const double *M, double *E, double *X, double *T);

/* An upper bound of e^{rate t} (rate >= 0; t < 0 counts as 0): 1 + x + x^2 for x = rate t <= 1 (e^x - 1 - x <=
 * (e - 2) x^2 there: no libm call per doStep), else e^x; exactly 1 at rate 0 (harness/rom/lti.py growth_factor). */
double rom_growth_factor(double rate, double t);

#endif /* SPHROM_ROM_NUMERICS_H */
