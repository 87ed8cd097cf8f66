/*
 * The dense numerics the model kinds and the error bounds share (rom_numerics.c): the matrix exponential.
 * It calls nothing of the core (rom_internal.h's inline helpers aside), so that every file that needs it
 * (rom_exact.c, rom_bound.c) sits above it in the call graph (rom_internal.h draws it; no circle).
 */
#ifndef SPHROM_ROM_NUMERICS_H
#define SPHROM_ROM_NUMERICS_H

#include "rom_internal.h"

/* E = e^M (n x n, row-major) by scaling and squaring with a Taylor polynomial; X, T: n x n scratch.
 * Returns 1 when E is finite, 0 when M or the result is not finite, n is 0 or a pointer is NULL. */
int rom_expm_taylor(size_t n, const double *M, double *E, double *X, double *T);

#endif /* SPHROM_ROM_NUMERICS_H */
