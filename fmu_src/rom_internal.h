/*
 * What the pieces of the model core share (private: not part of rom.h's API):
 * the table of operations of a model kind, and the helpers below it.
 *
 * A model kind (the header's model_kind) is one constant RomKindOps, in the
 * spirit of the Reference-FMUs' model.h contract: its own data (behind
 * RomModel.body and RomState.body), how it is loaded, laid out, reset, stepped,
 * observed, checked, assembled and serialized.  The common code never asks
 * which kind a model is: it calls the model's table.  The one place that maps
 * model_kind to a table is rom_resources.c (kind_ops) over rom_layout.h's
 * ROM_KIND_TABLES, generated from harness/fmu/layout.py KINDS: adding a kind is
 * one table in a file of its own (and a row there, a line of CMakeLists.txt).
 *
 * Who calls whom (calls through a table count; no circle, tests/test_fmu_sources.py proves it from the
 * objects' symbols: a kind file calls only the files at the bottom, never rom.c, rom_resources.c,
 * rom_state_io.c or rom_bound.c):
 *
 *   instance.c -> rom.c, rom_resources.c, rom_state_io.c, rom_envelope.c, rom_bound.c   (rom.h's API)
 *   rom.c ----------+
 *   rom_resources.c +-> the model's table: rom_frozen.c | rom_exact.c --+
 *   rom_state_io.c  |   (rom_resources.c also chooses it)               |
 *   rom_bound.c ----+                                                   v
 *   rom.c, rom_resources.c, rom_state_io.c -> rom_bound.c     rom_numerics.c, rom_bytes.c -> rom_fail.c
 *   rom.c, rom_resources.c, rom_state_io.c, rom_bound.c, rom_exact.c -> rom_port.c (the port channel)
 *   rom_resources.c -> rom_envelope.c (its sections' checks)
 *   rom_bound.c, rom_port.c -> rom_numerics.c (the matrix exponential), rom_bytes.c
 *   (and every file: rom_internal.h's inline helpers, rom_fail.c)
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

/* The shared resource header after magic and version (rom_layout.h ROM_HEADER_*) */
typedef struct {
    uint32_t kind, k_v, k_rho, n_probes, flags;
    double bound, L;
} RomHeader;

/* The operations of one model kind.  Every pointer is set unless its comment says "NULL:"; the common code
 * calls them with a checked model, state and probe index. */
struct RomKindOps {
    uint32_t kind;                 /* the header's model_kind (ROM_MODEL_*) */
    const char *name;              /* in the loader's messages: "the frozen-coefficient model", ... */
    const char *short_name;        /* in the sections' messages: "frozen", "linear" */

    /* ---- resources (rom_resources.c applies the header's rules in rom.h's order, the kind's among them) */
    const char *k_rho_name;        /* the header's k_rho in messages: "k_rho", "k_e" */
    const char *length_subject;    /* what the length check names before k_v: "", "the exact model with " */
    uint32_t flags;                /* the flag bits the kind reads */
    uint32_t (*min_k_rho)(const RomHeader *h);         /* the smallest k_rho the kind accepts */
    size_t head_size;              /* bytes of the kind's own header at the start of its body (0: none) */
    /* the kind's own header (head_size bytes at head, present) checked against the shared header h: *doubles
     * receives the float64 values of its arrays after it */
    RomStatus (*read_head)(const RomHeader *h, const unsigned char *head, uint64_t *doubles, char *message,
                           size_t message_size);
    /* read the kind's body (its header, then doubles values; the length checked) into m->body; sets m->probe_x
     * and m->input_width; m's common fields are set */
    RomStatus (*load)(RomModel *m, const unsigned char *body, uint64_t doubles, char *message,
                      size_t message_size);
    /* once the tagged sections are read and checked: the kind's use of its own sections (NULL: none) */
    RomStatus (*sections_ready)(RomModel *m, char *message, size_t message_size);
    void (*model_free)(RomModel *m);                   /* frees m->body (NULL: nothing) */
    const char *const *sections;       /* the tagged sections only this kind reads (NULL-terminated) */
    const char *const *param_sections; /* the sections PARAMS needs: the kind's affine pieces */
    /* the shape of one of the kind's affine pieces (a tag of sections) */
    void (*affine_shape)(const RomModel *m, const char *tag, uint32_t *rows, uint32_t *cols);
    /* the kind's rules on PARAMS, after the common ones */
    RomStatus (*check_params)(const RomModel *m, const RomSection *params, char *message, size_t message_size);

    /* ---- the state */
    RomStatus (*state_new)(RomState *s);               /* allocates s->body (the layout of the kind's arrays) */
    void (*state_free)(RomState *s);                   /* frees s->body (NULL: nothing) */
    /* a^v, a^rho and the kind's own initial state from s->initial_state_scale (av, ar are zeroed) */
    void (*initial_state)(RomState *s);
    void (*reset)(RomState *s);                        /* the kind's own state after a reset */

    /* ---- doStep */
    /* advance from t_comm over h > 0 (the internal steps of doStep; rom.c then sets the time, continues the
     * inputs and checks the outputs) */
    RomStatus (*step)(RomState *s, double t_comm, double h, char *message, size_t message_size);
    /* ---- internal steps (NULL, every one: the kind has none, it advances over any step exactly) */
    RomStatus (*advance)(RomState *s, int64_t n_steps, char *message, size_t message_size);
    int (*step_exceeds)(const RomState *s, double h);  /* dt exceeds the step h */
    double (*step_work)(const RomState *s);            /* multiply-adds of one internal step */
    double (*dt_floor)(const RomModel *m);             /* the smallest dt the state accepts [s] */
    RomStatus (*set_dt)(RomState *s, double dt, char *message, size_t message_size);          /* checked: > 0 */
    RomStatus (*set_n_freeze)(RomState *s, int32_t n_freeze, char *message, size_t message_size); /* >= 1 */
    double (*dt)(const RomState *s);
    int32_t (*n_freeze)(const RomState *s);

    /* ---- outputs and checks */
    double (*v_probe)(const RomState *s, uint32_t j);
    double (*rho_probe)(const RomState *s, uint32_t j);
    /* 1: rho_probe and rho_rate include the port channel's part (the linear kinds superpose its e in J); 0: rom.c
     * adds the linear SPH's density shift of the channel's e to the kind's density (the frozen kind) */
    int density_with_channel;
    /* the kind's check at probe j before the density's (NULL: none) */
    RomStatus (*check_probe)(const RomState *s, uint32_t j, char *message, size_t message_size);
    double (*v_rate)(const RomState *s, uint32_t j);   /* NULL: no output derivatives, no_rates says why */
    double (*rho_rate)(const RomState *s, uint32_t j);
    const char *no_rates;
    int envelope;                  /* 1: the training envelope is checked at run time (rom_envelope.c) */

    /* ---- parametric models: the operators at the state's c and d into the model (PARAMS present) */
    void (*assemble)(RomModel *m, RomState *s);

    /* ---- the serialized state: the kind's block between a^v, a^rho and (t0, df/dt) (rom_layout.h) */
    size_t (*state_doubles)(const RomModel *m);
    /* the kind's rules on its block at cursor (state_doubles values) of a serialized state (NULL: none beyond
     * the finite values every block has) */
    RomStatus (*state_check)(const RomModel *m, const unsigned char *cursor, char *message, size_t message_size);
    unsigned char *(*state_put)(const RomState *s, unsigned char *cursor);            /* returns the end */
    const unsigned char *(*state_get)(RomState *s, const unsigned char *cursor);      /* returns the end */

    /* ---- what rom.h reports of a kind */
    int64_t (*expm_count)(const RomState *s);          /* NULL: 0 (no exponentials) */
    const char *(*linear_name)(const RomModel *m);     /* NULL: not a linear model */
    /* one line on the model for the instance's log (sizes, the kind's own settings) into out[size] */
    void (*describe)(const RomModel *m, char *out, size_t size);
};

/* the kinds (rom_frozen.c, rom_exact.c): one function per kind returns its table (rom_layout.h ROM_KIND_TABLES,
 * generated from harness/fmu/layout.py KINDS, lists them) */
#define ROM_DECLARE_KIND(table) const RomKindOps *table(void);
ROM_KIND_TABLES(ROM_DECLARE_KIND)
#undef ROM_DECLARE_KIND

/* ---- helpers shared by every file (inline: no file depends on another for them) ---- */

static inline int rom_all_finite(const double *x, size_t n) {
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(x[i])) return 0;
    }
    return 1;
}

/* Whether a step of length h is the cached step h_cached: equal, or within ROM_SAME_STEP of it relative to the
 * step (rom.h).  An importer's step t[n+1] - t[n] of t = n H jitters by a few ulps of t, and each new length costs
 * a matrix exponential, O(k^3) in the model's order; the cached maps then integrate over h_cached, which differs
 * from h by less than 1e-9 of the step.  The tolerance is the step's, never the time's: at a start of 1.7e9 s
 * (an ulp of 2.4e-7 s) steps of 1e-6 s and 3.5e-6 s stay two steps. */
static inline int rom_same_step(double h, double h_cached) {
    if (h == h_cached) return 1;
    if (!(h_cached > 0.0)) return 0;
    return fabs(h - h_cached) <= ROM_SAME_STEP * h_cached;
}

static inline size_t rom_round_up(size_t n, size_t m) {
    return (n + m - 1) / m * m;
}

/* the section with this tag, NULL when the model has none (rom_model_section without the argument checks) */
static inline const RomSection *rom_section(const RomModel *m, const char *tag) {
    for (uint32_t i = 0; i < m->n_sections; i++) {
        if (strcmp(m->sections[i].tag, tag) == 0) return &m->sections[i];
    }
    return NULL;
}

/* the port inputs the kind itself takes: every port without the port channel, none with it (no PORTB) */
static inline uint32_t rom_port_inputs(const RomModel *m) {
    return m->port_B ? m->n_ports : 0u;
}

/* the kind's part of v_port_j: sum_q port_C[j][q] a^v_q from 0.0 in q order, and on over a^rho for a linear
 * model whose rows act on the whole state (flag output_rows: PORTC is P x (k_v + k_rho)); rom.h rom_v_port adds
 * the port channel's part */
static inline double rom_port_velocity(const RomState *s, uint32_t j) {
    const RomModel *m = s->model;
    const size_t kv = m->k_v, kr = (m->flags & ROM_FLAG_OUTPUT_ROWS) ? m->k_rho : 0;
    const double *row = m->port_C + (size_t)j * (kv + kr);
    double v = 0.0;
    for (size_t q = 0; q < kv; q++) v += row[q] * s->av[q];
    for (size_t q = 0; q < kr; q++) v += row[kv + q] * s->ar[q];
    return v;
}

/* The most internal steps one doStep takes when one step costs `work` multiply-adds, ROM_STEP_OVERHEAD included
 * (rom.h rom_max_steps_per_call: ROM_MAX_WORK_PER_CALL over it; 0 for no work) */
static inline double rom_steps_per_call(double work) {
    return work > 0.0 ? floor(ROM_MAX_WORK_PER_CALL / work) : 0.0;
}

/* the finiteness check every port input's setter shares (F_port_j, a_port_j and their rates; rom_port.c): ROM_OK for a
 * finite value, else ROM_FAIL with the message naming input name_{j+1}, "a finite <what> in N" (what NULL: the
 * input's derivative, d<name>/dt in N s^-1) */
RomStatus rom_check_port_input(const RomState *s, const char *name, uint32_t j, double value, const char *what,
                               char *message, size_t message_size);

/* ---- rom_port.c: the port channel (rom.h RomChannelModel) ---- */
RomStatus rom_channel_check_section(const RomModel *m, const RomSection *s, char *message, size_t message_size);
RomStatus rom_channel_prepare(RomModel *m, char *message, size_t message_size);   /* sizes of the PC* sections */
RomStatus rom_channel_state_new(RomState *s);     /* s->channel (NULL without the channel) */
void rom_channel_state_free(RomState *s);
void rom_channel_reset(RomState *s);
/* advance the channel over the step from the state's port inputs (before rom.c continues them); v_own[j] the
 * kind's v_port_j at the step's start and end averaged (the wave form's part of the mean port velocity), v_end[j]
 * the kind's v_port_j at the step's end, kept for rom_channel_kind_velocity (NULL: not known) */
RomStatus rom_channel_step(RomState *s, double h, const double *v_own, const double *v_end, char *message,
                           size_t message_size);
/* the kind's part of v_port_j (rom_port_velocity), kept from a step's end or its first read until
 * rom_channel_kind_moved: rom.c calls that (through rom_outputs_moved) wherever the kind's state changes outside a
 * read (before a step, at initial_state_scale, rom_advance, rom_model_assemble; a reset and a state read forget it
 * too).  Without the channel: rom_port_velocity itself */
double rom_channel_kind_velocity(const RomState *s, uint32_t j);
/* rom.h rom_v_port: the kind's part (rom_channel_kind_velocity) and the channel's row; without the channel the kind's */
double rom_channel_port_velocity(const RomState *s, uint32_t j);
void rom_channel_kind_moved(RomState *s);
/* rom.c: the kind's state moved (wherever a^v, a^rho or the kind's state change outside a read: a step, a reset,
 * initial_state_scale, rom_advance, dt, n_freeze, a new parameter, a state read): the kept v_probe (RomState.v_kept)
 * is forgotten and rom_channel_kind_moved called */
void rom_outputs_moved(RomState *s);
/* the channel's part of output row r (the shadow's order: P v probes, 2P e rows, the ports) with its certified
 * bound against the full linear SPH's port response in *cert (0 and 0 without the channel) */
double rom_channel_row(const RomState *s, uint32_t r, double *cert);
/* the time derivative of that part now (the exact model's output derivatives) */
double rom_channel_row_rate(const RomState *s, uint32_t r);
/* rom.h rom_v_probe for probe j < n_probes of s: the kind's v_probe, kept in RomState.v_kept until the state moves
 * (rom_outputs_moved; a NaN is asked anew, still NaN; without the error bounds not kept), plus the port channel's
 * part (without the channel the kind's own bits): the importer's read and the error check (rom_bound.c) share one
 * sum per state */
static inline double rom_v_probe_kept(const RomState *s, uint32_t j) {
    double v = s->v_kept ? s->v_kept[j] : NAN;
    if (isnan(v)) {
        v = s->model->ops->v_probe(s, j);
        if (s->v_kept) s->v_kept[j] = v;
    }
    return s->channel ? v + rom_channel_row(s, j, NULL) : v;
}
/* the linear SPH's density shift of the channel's e at probe j's two particles, sum_m pw_m rho0_m (1 / (1 + e_m) -
 * 1) [kg m^-3], added to a kind's density that does not hold it (the frozen kind's); NaN where 1 + e <= 0, 0
 * without the channel */
double rom_channel_density_shift(const RomState *s, uint32_t j);
size_t rom_channel_state_doubles(const RomModel *m);   /* in the serialized state, after the ports */
RomStatus rom_channel_state_check(const RomModel *m, const unsigned char *cursor, char *message, size_t message_size);
unsigned char *rom_channel_state_put(const RomState *s, unsigned char *cursor);
const unsigned char *rom_channel_state_get(RomState *s, const unsigned char *cursor);

/* ---- rom_bytes.c: little-endian numbers, the check both blob formats share, arrays ---- */

uint32_t rom_get_u32(const unsigned char *p);
uint64_t rom_get_u64(const unsigned char *p);
double rom_get_f64(const unsigned char *p);
void rom_put_u32(unsigned char *p, uint32_t v);
void rom_put_u64(unsigned char *p, uint64_t v);
void rom_put_f64(unsigned char *p, double value);
/* n float64 values from cursor into out; returns the cursor after them */
const unsigned char *rom_get_f64s(const unsigned char *cursor, double *out, size_t n);
/* n float64 values from values to cursor; returns the cursor after them */
unsigned char *rom_put_f64s(unsigned char *cursor, const double *values, size_t n);

/* A versioned blob's format (resources/model.bin, a serialized state), for the checks both share: magic,
 * version, length, token, checksum; the strings name the blob in messages */
typedef struct {
    const char *what;          /* the messages' subject */
    const char *magic;         /* 8 bytes */
    const char *contents;      /* what the magic announces */
    const char *empty;         /* what the smallest valid blob is */
    const char *one;           /* one such blob, in messages */
    const char *damaged;       /* what is truncated or corrupt when a check fails */
    uint32_t version;          /* the version written and read */
    uint32_t oldest;           /* the oldest version read (the reader converts it; = version: none older) */
    size_t min_size;           /* bytes needed before the header can be read */
    const char *older;         /* why an older version is not read, in messages */
} RomBlob;

/* Size, magic and version: then the header can be read */
RomStatus rom_blob_open(const RomBlob *e, const unsigned char *bytes, size_t size, char *message,
                        size_t message_size);
/* Once the caller has checked the header's sizes: the token when it must be a given one, the length (detail
 * says what it was computed for), the checksum of every byte before the last four, the token's form */
RomStatus rom_blob_close(const RomBlob *e, const unsigned char *bytes, size_t size, uint64_t expected,
                         const char *detail, size_t token_offset, const char *token, char *message,
                         size_t message_size);

/* One zeroed block for arrays of the given double counts, each 64-byte aligned; *ptrs[i] receives array i
 * (NULL for a count of 0).  Returns the block to free (NULL when out of memory or on a bad argument). */
void *rom_alloc_arrays(const size_t *counts, double **ptrs[], int n);
/* 1 when every array of ptrs (counts values each; NULL ones skipped) is finite */
int rom_arrays_finite(double **ptrs[], const size_t *counts, int n);

/* ---- rom_envelope.c: shape checks of the envelope's sections (rows of rom_resources.c's SECTION_RULES) ---- */
RomStatus rom_envelope_check_scalars(const RomModel *m, const RomSection *s, char *message, size_t message_size);
RomStatus rom_envelope_check_range(const RomModel *m, const RomSection *s, char *message, size_t message_size);
RomStatus rom_envelope_check_probe(const RomModel *m, const RomSection *s, char *message, size_t message_size);
RomStatus rom_envelope_check_ports(const RomModel *m, const RomSection *s, char *message, size_t message_size);

/* ---- rom_bound.c: the certified error bounds (rom.h) ---- */
RomStatus rom_bound_check_section(const RomModel *m, const RomSection *s, char *message, size_t message_size);
RomStatus rom_bound_prepare(RomModel *m, char *message, size_t message_size);   /* sizes of the SH* sections */
/* a parametric shadow (SHPIECE, SHPARAM): its planes, growth rate, residual norm and the e rows' scale at the
 * state's c and d into the model, the state's plane maps emptied (rom_model_assemble; nothing without pieces) */
RomStatus rom_bound_assemble(RomModel *m, RomState *s, char *message, size_t message_size);
RomStatus rom_bound_state_new(RomState *s);        /* s->bound (NULL without bounds) */
void rom_bound_state_free(RomState *s);
void rom_bound_reset(RomState *s);
/* advance the shadow over the step from the state's inputs (before rom.c continues them) */
void rom_bound_step(RomState *s, double h);
size_t rom_bound_state_doubles(const RomModel *m);  /* in the serialized state, after the ports */
unsigned char *rom_bound_state_put(const RomState *s, unsigned char *cursor);
const unsigned char *rom_bound_state_get(RomState *s, const unsigned char *cursor);

#endif /* SPHROM_ROM_INTERNAL_H */
