/*
 * What the pieces of the model core share (private: not part of rom.h's API).
 *
 *   rom.c         state API, dispatch by model kind
 *   rom_io.c      resources, checksums, serialized states (one envelope check)
 *   rom_frozen.c  the frozen-coefficient step (eqs. 2.19-2.24)
 *   rom_exact.c   the exact linear model: exponentials, their cache, the Schur path
 *
 * Include this header first: the pragmas below keep the arithmetic free of
 * fused multiply-adds (the outputs equal the Python reference bit for bit)
 * also when a compiler rebuilds the FMU from its sources/ folder without our
 * -ffp-contract=off.
 */
#ifndef SPHROM_ROM_INTERNAL_H
#define SPHROM_ROM_INTERNAL_H

#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include "rom.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

/* The code path of a model kind.  Every linear kind (the exact model, and any
 * later one that differs from it only in its matrices) runs the exact model's
 * path, loader and serialization included: adding such a kind is one case here
 * (and its name in rom_io.c's message on unsupported kinds). */
typedef enum { ROM_PATH_NONE = 0, ROM_PATH_FROZEN = 1, ROM_PATH_LINEAR = 2 } RomPath;

static inline RomPath rom_path(uint32_t kind) {
    switch (kind) {
        case ROM_MODEL_FROZEN: return ROM_PATH_FROZEN;
        case ROM_MODEL_EXACT_LINEAR: return ROM_PATH_LINEAR;
        default: return ROM_PATH_NONE;
    }
}

static inline int rom_is_linear(const RomModel *m) {
    return rom_path(m->kind) == ROM_PATH_LINEAR;
}

/* inputs of a linear model: f (when B is present), then the port forces */
static inline size_t rom_linear_inputs(const RomModel *m) {
    return (m->B ? 1u : 0u) + m->n_ports;
}

static inline int rom_all_finite(const double *x, size_t n) {
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(x[i])) return 0;
    }
    return 1;
}

static inline size_t rom_round_up(size_t n, size_t m) {
    return (n + m - 1) / m * m;
}

/* rom.c: one zeroed block for arrays of the given double counts, each 64-byte
 * aligned; *ptrs[i] receives array i (NULL for a count of 0).  Returns the block
 * to free (NULL when out of memory). */
void *rom_alloc_arrays(const size_t *counts, double **ptrs[], int n);

/* rom_frozen.c: advance over [t_comm, t_comm + h] in whole internal steps of dt and
 * one shortened last step; and n whole steps from the state's time */
RomStatus rom_frozen_step(RomState *s, double t_comm, double h, char *message, size_t message_size);
RomStatus rom_frozen_advance(RomState *s, int64_t n_steps, char *message, size_t message_size);
double rom_frozen_rho_probe(const RomState *s, uint32_t j);

/* rom_exact.c: y0 = Q^T z0 once the model is read; one exact step over h (input held, or
 * linear at the state's rate); n steps of dt; the density at a probe (rho0/J) */
void rom_exact_prepare(RomModel *m);
RomStatus rom_exact_step(RomState *s, double t_comm, double h, char *message, size_t message_size);
RomStatus rom_exact_advance(RomState *s, int64_t n_steps, char *message, size_t message_size);
double rom_exact_rho_probe(const RomState *s, uint32_t j);
/* a probe row over the whole state z = (a; b) times z (rom.h: kind 2's rows) */
double rom_exact_output(const RomState *s, const double *row);
/* the smaller J = 1 + e of the probe's two particles (NaN when not finite) */
double rom_exact_probe_J(const RomState *s, uint32_t j);
/* dv_j/dt and drho_j/dt of a linear model (rom_v_probe_rate, rom_rho_probe_rate) */
double rom_exact_v_rate(const RomState *s, uint32_t j);
double rom_exact_rho_rate(const RomState *s, uint32_t j);

/* shape checks of the envelope's sections (rom_envelope.c; rows of rom_io.c's SECTION_RULES) */
RomStatus rom_envelope_check_scalars(const RomModel *m, const RomSection *s, char *message, size_t message_size);
RomStatus rom_envelope_check_range(const RomModel *m, const RomSection *s, char *message, size_t message_size);
RomStatus rom_envelope_check_probe(const RomModel *m, const RomSection *s, char *message, size_t message_size);
RomStatus rom_envelope_check_ports(const RomModel *m, const RomSection *s, char *message, size_t message_size);

#endif /* SPHROM_ROM_INTERNAL_H */
