/*
 * sphrom model core: the frozen-coefficient reduced model (eqs. 2.19-2.24).
 * See rom.h for the resource format and the API.
 *
 * The step repeats harness/rom/frozen.py (frozen_advance) operation for
 * operation, in the same order, so that the FMU equals the Python reference
 * bit for bit.  That needs no fused multiply-add contraction: the build uses
 * -ffp-contract=off and the pragmas below cover compilers that rebuild the
 * FMU from its sources/ folder without our flags.
 */
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

#include "rom.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ROM_VERSION_STRING "sphrom-core 2"
#define ROM_MAX_FILE_SIZE ((size_t)1 << 30)    /* 1 GiB: far above any k <= 100 model */
#define ROM_STATE_HEADER_SIZE 112
#define ROM_TIME_TOLERANCE 1e-9                /* relative, for currentCommunicationPoint */
#define ROM_STEP_ROUNDING 1e-9                 /* relative, h/dt taken as a whole number */
#define ROM_SHORT_STEP_MIN 1e-12               /* remainders below this x dt are dropped */
#define ROM_MAX_STEPS_PER_CALL 1e15

static const char STATE_MAGIC[8] = {'S', 'P', 'H', 'R', 'O', 'M', 'S', 'T'};
static const char RESOURCE_MAGIC[8] = {'S', 'P', 'H', 'R', 'O', 'M', 'R', 'S'};

/* ------------------------------------------------------------------------ */
/* small helpers                                                             */
/* ------------------------------------------------------------------------ */

static RomStatus fail(char *message, size_t message_size, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static RomStatus fail(char *message, size_t message_size, const char *format, ...) {
    if (message && message_size > 0) {
        va_list args;
        va_start(args, format);
        vsnprintf(message, message_size, format, args);
        va_end(args);
    }
    return ROM_FAIL;
}

static uint32_t get_u32(const unsigned char *p) {
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static uint64_t get_u64(const unsigned char *p) {
    return (uint64_t)get_u32(p) | ((uint64_t)get_u32(p + 4) << 32);
}

static double get_f64(const unsigned char *p) {
    const uint64_t bits = get_u64(p);
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static void put_u32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)(v & 0xffu);
    p[1] = (unsigned char)((v >> 8) & 0xffu);
    p[2] = (unsigned char)((v >> 16) & 0xffu);
    p[3] = (unsigned char)((v >> 24) & 0xffu);
}

static void put_u64(unsigned char *p, uint64_t v) {
    put_u32(p, (uint32_t)(v & 0xffffffffu));
    put_u32(p + 4, (uint32_t)(v >> 32));
}

static void put_f64(unsigned char *p, double value) {
    uint64_t bits;
    memcpy(&bits, &value, sizeof bits);
    put_u64(p, bits);
}

uint32_t rom_crc32(const void *data, size_t size) {
    /* zlib's CRC-32 (reflected polynomial 0xEDB88320); the table lives on the
     * stack so that there is no global state */
    uint32_t table[256];
    for (uint32_t i = 0; i < 256; i++) {
        uint32_t c = i;
        for (int k = 0; k < 8; k++) {
            c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
        }
        table[i] = c;
    }
    const unsigned char *bytes = (const unsigned char *)data;
    uint32_t crc = 0xFFFFFFFFu;
    for (size_t i = 0; i < size; i++) {
        crc = table[(crc ^ bytes[i]) & 0xFFu] ^ (crc >> 8);
    }
    return crc ^ 0xFFFFFFFFu;
}

const char *rom_version(void) {
    return ROM_VERSION_STRING;
}

static int valid_token(const char *token) {
    /* "{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}" with lower-case hex digits */
    static const char pattern[] = "{hhhhhhhh-hhhh-hhhh-hhhh-hhhhhhhhhhhh}";
    for (size_t i = 0; i + 1 < sizeof pattern; i++) {
        const char c = token[i];
        if (pattern[i] == 'h') {
            if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return 0;
        } else if (c != pattern[i]) {
            return 0;
        }
    }
    return token[sizeof pattern - 1] == '\0';
}

static int all_finite(const double *x, size_t n) {
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(x[i])) return 0;
    }
    return 1;
}

#if defined(__GNUC__)
#define ROM_INLINE static inline __attribute__((always_inline))
#else
#define ROM_INLINE static inline
#endif

/* The stepping loop is compiled for AVX-512, AVX2 and the baseline and picked
 * at load time (GCC function multiversioning, x86-64 Linux).  Vector lanes
 * compute exactly what the scalar code does (no reassociation, no FMA), so
 * every variant gives the same bits. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(ROM_NO_CLONES) && (__GNUC__ >= 8)
#define ROM_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define ROM_CLONES
#endif

static size_t round_up(size_t n, size_t m) {
    return (n + m - 1) / m * m;
}

/* A zeroed block for arrays of the given double counts, each 64-byte aligned;
 * ptrs[i] receives array i (NULL for a count of 0).  Returns the block to free. */
static void *alloc_arrays(const size_t *counts, double **ptrs[], int n) {
    size_t total = 8;   /* slack for aligning the start */
    for (int i = 0; i < n; i++) total += round_up(counts[i], 8);
    unsigned char *raw = (unsigned char *)calloc(total, sizeof(double));
    if (!raw) return NULL;
    double *cursor = (double *)(void *)(raw + ((64 - ((uintptr_t)raw & 63u)) & 63u));
    for (int i = 0; i < n; i++) {
        *ptrs[i] = counts[i] ? cursor : NULL;
        cursor += round_up(counts[i], 8);
    }
    return raw;
}

/* ------------------------------------------------------------------------ */
/* resources                                                                 */
/* ------------------------------------------------------------------------ */

typedef struct {
    uint64_t a_v0, a_rho0, K, b, D, p, T, Pv, Prho, probe_x, total;
} Counts;

static Counts double_counts(uint64_t kv, uint64_t kr, uint64_t np, uint64_t npairs, uint32_t flags) {
    Counts c;
    c.a_v0 = kv;
    c.a_rho0 = kr;
    c.K = kv * kr;
    c.b = kv;
    c.D = (flags & ROM_FLAG_DAMPING) ? kv * kv : 0;
    c.p = (flags & ROM_FLAG_INPUT) ? kv : 0;
    c.T = npairs * kr * kv;
    c.Pv = np * kv;
    c.Prho = np * kr;
    c.probe_x = np;
    c.total = c.a_v0 + c.a_rho0 + c.K + c.b + c.D + c.p + c.T + c.Pv + c.Prho + c.probe_x;
    return c;
}

static void read_doubles(const unsigned char **cursor, double *out, uint64_t n) {
    for (uint64_t i = 0; i < n; i++) {
        out[i] = get_f64(*cursor);
        *cursor += 8;
    }
}

/* The exact linear model (kind 2): header checks, sizes, checksum, operators.
 * Called by rom_model_load_memory once magic, version and kind are read. */
static RomStatus load_exact(const unsigned char *bytes, size_t size, RomModel **out, char *message,
                            size_t message_size) {
    const uint32_t integrator = get_u32(bytes + 16);
    const uint32_t kv = get_u32(bytes + 20), ke = get_u32(bytes + 24), np = get_u32(bytes + 28);
    const uint32_t npairs = get_u32(bytes + 32), flags = get_u32(bytes + 36);
    const uint32_t n_freeze = get_u32(bytes + 40), reserved = get_u32(bytes + 44);
    const double dt = get_f64(bytes + 48), bound = get_f64(bytes + 56), L = get_f64(bytes + 64);
    if (integrator != 0) {
        return fail(message, message_size, "resources: integrator %u given for the exact model (must be 0: it "
                    "is advanced by the matrix exponential)", integrator);
    }
    if (kv < 1 || kv > ROM_MAX_MODES || ke < 1 || ke > ROM_MAX_MODES) {
        return fail(message, message_size, "resources: mode counts k_v = %u, k_e = %u out of range [1, %u]",
                    kv, ke, ROM_MAX_MODES);
    }
    if (np < 1 || np > ROM_MAX_PROBES) {
        return fail(message, message_size, "resources: %u probes, out of range [1, %u]", np, ROM_MAX_PROBES);
    }
    if (npairs != 0) return fail(message, message_size, "resources: n_pairs = %u, must be 0 for the exact model",
                                 npairs);
    if (flags & ~(ROM_FLAG_DAMPING | ROM_FLAG_INPUT | ROM_FLAG_SCHUR)) {
        return fail(message, message_size, "resources: unknown flag bits 0x%x", flags);
    }
    if ((flags & ROM_FLAG_SCHUR) && (flags & ROM_FLAG_DAMPING)) {
        return fail(message, message_size, "resources: flag bits 0x%x: a Schur form with damping (the free "
                    "response by rotations needs a skew operator)", flags);
    }
    if (n_freeze < 1 || n_freeze > INT32_MAX || reserved != 0) {
        return fail(message, message_size, "resources: n_freeze_default = %u (must be >= 1) or reserved = %u "
                    "(must be 0)", n_freeze, reserved);
    }
    const uint64_t k = (uint64_t)kv + ke;
    const uint64_t cB = (flags & ROM_FLAG_INPUT) ? k : 0, cQ = (flags & ROM_FLAG_SCHUR) ? k * k : 0;
    const uint64_t total = k + k * k + cB + 2 * cQ + (uint64_t)np * kv + (uint64_t)np * 2 * ke + 4 * (uint64_t)np +
                           np;
    const uint64_t expected = (uint64_t)ROM_HEADER_SIZE + 8u * total + ROM_TOKEN_SIZE + 4u;
    if ((uint64_t)size != expected) {
        return fail(message, message_size,
                    "resources: %zu bytes, expected %llu for the exact model with k_v = %u, k_e = %u, %u probes, "
                    "flags 0x%x (file truncated or corrupt)", size, (unsigned long long)expected, kv, ke, np, flags);
    }
    const uint32_t stored_crc = get_u32(bytes + size - 4);
    const uint32_t crc = rom_crc32(bytes, size - 4);
    if (crc != stored_crc) {
        return fail(message, message_size, "resources: checksum mismatch (stored 0x%08x, computed 0x%08x): "
                    "file corrupt", stored_crc, crc);
    }
    if (!(isfinite(dt) && dt > 0)) {
        return fail(message, message_size, "resources: dt = %g (must be finite and > 0)", dt);
    }
    if (!(isfinite(bound) && bound > 0) || !(isfinite(L) && L > 0)) {
        return fail(message, message_size, "resources: runaway bound %g and L %g must be finite and > 0", bound, L);
    }
    const char *token = (const char *)(bytes + size - 4 - ROM_TOKEN_SIZE);
    if (!valid_token(token)) return fail(message, message_size, "resources: the token field is not a GUID string");

    RomModel *m = (RomModel *)calloc(1, sizeof(RomModel));
    if (!m) return fail(message, message_size, "resources: out of memory");
    m->kind = ROM_MODEL_EXACT_LINEAR;
    m->integrator = 0;
    m->k_v = kv;
    m->k_rho = ke;
    m->k = (uint32_t)k;
    m->n_probes = np;
    m->n_pairs = 0;
    m->flags = flags;
    m->n_freeze_default = n_freeze;
    m->kv_pad = (uint32_t)round_up(kv, 4);
    m->kr_pad = (uint32_t)round_up(ke, 4);
    m->nm = 0;
    m->dt = dt;
    m->runaway_bound = bound;
    m->L = L;
    const size_t counts[11] = {k, k * k, cB, cQ, cQ, cQ ? k : 0, (size_t)np * kv, (size_t)np * 2 * ke, 2 * (size_t)np,
                               2 * (size_t)np, np};
    double **ptrs[11] = {&m->z0, &m->A, &m->B, &m->Q, &m->S, &m->y0, &m->Pv, &m->Pe, &m->pw, &m->prho0,
                         &m->probe_x};
    m->storage_ = alloc_arrays(counts, ptrs, 11);
    if (!m->storage_) {
        free(m);
        return fail(message, message_size, "resources: out of memory (%llu values)", (unsigned long long)total);
    }
    const unsigned char *cursor = bytes + ROM_HEADER_SIZE;
    read_doubles(&cursor, m->z0, k);
    read_doubles(&cursor, m->A, k * k);
    if (m->B) read_doubles(&cursor, m->B, k);
    if (m->Q) {
        read_doubles(&cursor, m->Q, k * k);
        read_doubles(&cursor, m->S, k * k);
    }
    read_doubles(&cursor, m->Pv, (uint64_t)np * kv);
    read_doubles(&cursor, m->Pe, (uint64_t)np * 2 * ke);
    read_doubles(&cursor, m->pw, 2 * (uint64_t)np);
    read_doubles(&cursor, m->prho0, 2 * (uint64_t)np);
    read_doubles(&cursor, m->probe_x, np);
    memcpy(m->token, token, ROM_TOKEN_SIZE);
    m->token[ROM_TOKEN_SIZE] = '\0';
    m->a_v0 = m->z0;
    m->a_rho0 = m->z0 + kv;
    int finite = 1;
    for (int i = 0; i < 11; i++) finite &= !*ptrs[i] || all_finite(*ptrs[i], counts[i]);
    if (!finite) {
        rom_model_free(m);
        return fail(message, message_size, "resources: non-finite numbers in the operators");
    }
    for (uint32_t j = 0; j < np; j++) {
        const double x = m->probe_x[j], w0 = m->pw[2 * j], w1 = m->pw[2 * j + 1];
        if (x < 0.0 || x > 1.0 || w0 < 0.0 || w1 < 0.0 || fabs(w0 + w1 - 1.0) > 1e-12 || !(m->prho0[2 * j] > 0) ||
            !(m->prho0[2 * j + 1] > 0)) {
            rom_model_free(m);
            return fail(message, message_size, "resources: probe %u: x/L = %g outside [0, 1], or weights %g, %g "
                        "not a convex pair, or rho0 <= 0", j + 1, x, w0, w1);
        }
    }
    if (m->Q) {                      /* y0 = Q^T z0 */
        for (size_t i = 0; i < k; i++) {
            double acc = 0.0;
            for (size_t r = 0; r < k; r++) acc += m->Q[r * k + i] * m->z0[r];
            m->y0[i] = acc;
        }
    }
    *out = m;
    return ROM_OK;
}

RomStatus rom_model_load_memory(const void *data, size_t size, RomModel **out, char *message, size_t message_size) {
    if (!out) return fail(message, message_size, "resources: no output pointer");
    *out = NULL;
    if (!data) return fail(message, message_size, "resources: no data");
    const unsigned char *bytes = (const unsigned char *)data;
    if (size < ROM_HEADER_SIZE + ROM_TOKEN_SIZE + 4) {
        return fail(message, message_size,
                    "resources truncated: %zu bytes, fewer than the %d of an empty model", size,
                    ROM_HEADER_SIZE + ROM_TOKEN_SIZE + 4);
    }
    if (memcmp(bytes, RESOURCE_MAGIC, 8) != 0) {
        return fail(message, message_size, "resources: bad magic (not an sphrom model.bin)");
    }
    const uint32_t version = get_u32(bytes + 8);
    if (version != ROM_FORMAT_VERSION) {
        return fail(message, message_size, "resources: format version %u is not supported (this binary reads %u)",
                    version, ROM_FORMAT_VERSION);
    }
    const uint32_t kind = get_u32(bytes + 12);
    if (kind != ROM_MODEL_FROZEN && kind != ROM_MODEL_EXACT_LINEAR) {
        return fail(message, message_size,
                    "resources: model kind %u is not supported by this binary (it runs kinds %u, the "
                    "frozen-coefficient model, and %u, the exact linear model)", kind, ROM_MODEL_FROZEN,
                    ROM_MODEL_EXACT_LINEAR);
    }
    if (kind == ROM_MODEL_EXACT_LINEAR) return load_exact(bytes, size, out, message, message_size);
    const uint32_t integrator = get_u32(bytes + 16);
    const uint32_t kv = get_u32(bytes + 20), kr = get_u32(bytes + 24), np = get_u32(bytes + 28);
    const uint32_t npairs = get_u32(bytes + 32), flags = get_u32(bytes + 36);
    const uint32_t n_freeze = get_u32(bytes + 40), reserved = get_u32(bytes + 44);
    const double dt = get_f64(bytes + 48), bound = get_f64(bytes + 56), L = get_f64(bytes + 64);
    if (integrator != ROM_INTEGRATOR_EULER && integrator != ROM_INTEGRATOR_SYMPLECTIC) {
        return fail(message, message_size, "resources: integrator %u is not one of 0 (euler), 1 (symplectic)",
                    integrator);
    }
    if (kv < 1 || kv > ROM_MAX_MODES || kr < 1 || kr > ROM_MAX_MODES) {
        return fail(message, message_size, "resources: mode counts k_v = %u, k_rho = %u out of range [1, %u]",
                    kv, kr, ROM_MAX_MODES);
    }
    if (np < 1 || np > ROM_MAX_PROBES) {
        return fail(message, message_size, "resources: %u probes, out of range [1, %u]", np, ROM_MAX_PROBES);
    }
    if ((uint64_t)npairs != (uint64_t)kr * (kr + 1) / 2) {
        return fail(message, message_size, "resources: n_pairs = %u, expected k_rho (k_rho + 1)/2 = %u", npairs,
                    kr * (kr + 1) / 2);
    }
    if (flags & ~(ROM_FLAG_DAMPING | ROM_FLAG_INPUT)) {
        return fail(message, message_size, "resources: unknown flag bits 0x%x", flags);
    }
    if (n_freeze < 1 || n_freeze > INT32_MAX || reserved != 0) {
        return fail(message, message_size, "resources: n_freeze_default = %u (must be >= 1) or reserved = %u "
                    "(must be 0)", n_freeze, reserved);
    }
    const Counts c = double_counts(kv, kr, np, npairs, flags);
    const uint64_t expected = (uint64_t)ROM_HEADER_SIZE + 8u * c.total + ROM_TOKEN_SIZE + 4u;
    if ((uint64_t)size != expected) {
        return fail(message, message_size,
                    "resources: %zu bytes, expected %llu for k_v = %u, k_rho = %u, %u probes, flags 0x%x "
                    "(file truncated or corrupt)", size, (unsigned long long)expected, kv, kr, np, flags);
    }
    const uint32_t stored_crc = get_u32(bytes + size - 4);
    const uint32_t crc = rom_crc32(bytes, size - 4);
    if (crc != stored_crc) {
        return fail(message, message_size, "resources: checksum mismatch (stored 0x%08x, computed 0x%08x): "
                    "file corrupt", stored_crc, crc);
    }
    if (!(isfinite(dt) && dt > 0)) {
        return fail(message, message_size, "resources: dt = %g (must be finite and > 0)", dt);
    }
    if (!(isfinite(bound) && bound > 0) || !(isfinite(L) && L > 0)) {
        return fail(message, message_size, "resources: runaway bound %g and L %g must be finite and > 0", bound, L);
    }
    const char *token = (const char *)(bytes + size - 4 - ROM_TOKEN_SIZE);
    if (!valid_token(token)) {
        return fail(message, message_size, "resources: the token field is not a GUID string");
    }

    RomModel *m = (RomModel *)calloc(1, sizeof(RomModel));
    if (!m) return fail(message, message_size, "resources: out of memory");
    m->kind = ROM_MODEL_FROZEN;
    m->integrator = integrator;
    m->k_v = kv;
    m->k_rho = kr;
    m->n_probes = np;
    m->n_pairs = npairs;
    m->flags = flags;
    m->n_freeze_default = n_freeze;
    m->kv_pad = (uint32_t)round_up(kv, 4);
    m->kr_pad = (uint32_t)round_up(kr, 4);
    m->nm = (uint32_t)round_up((size_t)kv * m->kr_pad, 32);
    m->dt = dt;
    m->runaway_bound = bound;
    m->L = L;
    const size_t kvp = m->kv_pad, krp = m->kr_pad, nm = m->nm;
    const size_t counts[10] = {kv, kr, kr * kvp, kvp, c.D ? kv * kvp : 0, c.p ? kvp : 0, (size_t)npairs * nm,
                               (size_t)c.Pv, (size_t)c.Prho, np};
    double **ptrs[10] = {&m->a_v0, &m->a_rho0, &m->Kt, &m->b, &m->Dt, &m->p, &m->Tt, &m->Pv, &m->Prho, &m->probe_x};
    m->storage_ = alloc_arrays(counts, ptrs, 10);
    if (!m->storage_) {
        free(m);
        return fail(message, message_size, "resources: out of memory (%llu values)", (unsigned long long)c.total);
    }

    const unsigned char *cursor = bytes + ROM_HEADER_SIZE;
    read_doubles(&cursor, m->a_v0, c.a_v0);
    read_doubles(&cursor, m->a_rho0, c.a_rho0);
    for (size_t p = 0; p < kv; p++) {                    /* K[p][q] -> Kt[q*kv_pad + p] */
        for (size_t q = 0; q < kr; q++, cursor += 8) m->Kt[q * kvp + p] = get_f64(cursor);
    }
    read_doubles(&cursor, m->b, c.b);
    if (m->Dt) {
        for (size_t p = 0; p < kv; p++) {
            for (size_t q = 0; q < kv; q++, cursor += 8) m->Dt[q * kvp + p] = get_f64(cursor);
        }
    }
    if (m->p) read_doubles(&cursor, m->p, c.p);
    /* T[k][p][q] is entry i = q*kr_pad + p of pair k's M^T; entries are
     * stored in blocks of 32, each block's pairs contiguous:
     * Tt[(i/32)*n_pairs*32 + k*32 + i%32] */
    for (size_t k = 0; k < npairs; k++) {
        for (size_t p = 0; p < kr; p++) {
            for (size_t q = 0; q < kv; q++, cursor += 8) {
                const size_t i = q * krp + p;
                m->Tt[(i / 32) * npairs * 32 + k * 32 + i % 32] = get_f64(cursor);
            }
        }
    }
    (void)nm;
    read_doubles(&cursor, m->Pv, c.Pv);
    read_doubles(&cursor, m->Prho, c.Prho);
    read_doubles(&cursor, m->probe_x, c.probe_x);
    memcpy(m->token, token, ROM_TOKEN_SIZE);
    m->token[ROM_TOKEN_SIZE] = '\0';

    const double *arrays[10] = {m->a_v0, m->a_rho0, m->Kt, m->b, m->Dt, m->p, m->Tt, m->Pv, m->Prho, m->probe_x};
    int finite = 1;
    for (int i = 0; i < 10; i++) finite &= !arrays[i] || all_finite(arrays[i], counts[i]);
    if (!finite) {
        rom_model_free(m);
        return fail(message, message_size, "resources: non-finite numbers in the operators");
    }
    for (uint32_t j = 0; j < np; j++) {
        if (m->probe_x[j] < 0.0 || m->probe_x[j] > 1.0) {
            const double x = m->probe_x[j];
            rom_model_free(m);
            return fail(message, message_size, "resources: probe %u at x/L = %g is outside [0, 1]", j + 1, x);
        }
    }
    *out = m;
    return ROM_OK;
}

RomStatus rom_model_load_file(const char *path, RomModel **out, char *message, size_t message_size) {
    if (!out) return fail(message, message_size, "resources: no output pointer");
    *out = NULL;
    if (!path) return fail(message, message_size, "resources: no path");
    errno = 0;
    FILE *file = fopen(path, "rb");
    if (!file) {
        const int err = errno;
        return fail(message, message_size, "resources file '%s' %s", path,
                    err == ENOENT ? "not found" : err == EACCES ? "is not readable (permission denied)"
                                                                 : "cannot be opened");
    }
    unsigned char *buffer = NULL;
    size_t size = 0, capacity = 0;
    RomStatus status = ROM_OK;
    for (;;) {
        if (size == capacity) {
            if (capacity >= ROM_MAX_FILE_SIZE) {
                status = fail(message, message_size, "resources file '%s' is larger than %zu bytes", path,
                              ROM_MAX_FILE_SIZE);
                break;
            }
            const size_t grown = capacity ? 2 * capacity : 65536;
            unsigned char *bigger = (unsigned char *)realloc(buffer, grown);
            if (!bigger) {
                status = fail(message, message_size, "resources file '%s': out of memory", path);
                break;
            }
            buffer = bigger;
            capacity = grown;
        }
        const size_t got = fread(buffer + size, 1, capacity - size, file);
        size += got;
        if (got == 0) {
            if (ferror(file)) status = fail(message, message_size, "resources file '%s': read error", path);
            break;
        }
    }
    fclose(file);
    if (status == ROM_OK) {
        char inner[ROM_MESSAGE_SIZE];
        inner[0] = '\0';
        status = rom_model_load_memory(buffer, size, out, inner, sizeof inner);
        if (status != ROM_OK) fail(message, message_size, "'%s': %s", path, inner);
    }
    free(buffer);
    return status;
}

void rom_model_free(RomModel *model) {
    if (!model) return;
    free(model->storage_);
    free(model);
}

/* ------------------------------------------------------------------------ */
/* state                                                                     */
/* ------------------------------------------------------------------------ */

RomState *rom_state_new(const RomModel *model) {
    if (!model) return NULL;
    RomState *s = (RomState *)calloc(1, sizeof(RomState));
    if (!s) return NULL;
    if (model->kind == ROM_MODEL_EXACT_LINEAR) {
        const size_t k = model->k, n = k + 2;
        const size_t kk = k * k;
        const size_t counts[5 + 3 * ROM_EXACT_CACHE] = {model->kv_pad, model->kr_pad, k, 2, 4 * n * n + 2 * k,
                                                        kk, k, k, kk, k, k};
        double **ptrs[4 + 3 * ROM_EXACT_CACHE + 1] = {&s->av, &s->ar, &s->X, &s->aux, &s->work,
                                                      &s->cache[0].Phi, &s->cache[0].G0, &s->cache[0].G1,
                                                      &s->cache[1].Phi, &s->cache[1].G0, &s->cache[1].G1};
        s->storage_ = alloc_arrays(counts, ptrs, 5 + 3 * ROM_EXACT_CACHE);
        if (!s->storage_) {
            free(s);
            return NULL;
        }
        s->model = model;
        rom_state_reset(s, 0.0);
        return s;
    }
    const size_t counts[7] = {model->kv_pad, model->kr_pad, model->nm, model->kv_pad, model->kv_pad, model->kr_pad,
                              model->n_pairs};
    double **ptrs[7] = {&s->av, &s->ar, &s->Mt, &s->F, &s->dv, &s->dr, &s->S};
    s->storage_ = alloc_arrays(counts, ptrs, 7);
    if (!s->storage_) {
        free(s);
        return NULL;
    }
    s->model = model;
    rom_state_reset(s, 0.0);
    return s;
}

void rom_state_free(RomState *state) {
    if (!state) return;
    free(state->storage_);
    free(state);
}

void rom_state_reset(RomState *s, double t_start) {
    if (!s) return;
    const RomModel *m = s->model;
    memset(s->av, 0, m->kv_pad * sizeof(double));
    memset(s->ar, 0, m->kr_pad * sizeof(double));
    memcpy(s->av, m->a_v0, m->k_v * sizeof(double));
    memcpy(s->ar, m->a_rho0, m->k_rho * sizeof(double));
    if (s->Mt) memset(s->Mt, 0, (size_t)m->nm * sizeof(double));
    if (s->F) memset(s->F, 0, m->kv_pad * sizeof(double));
    if (m->kind == ROM_MODEL_EXACT_LINEAR) {
        if (m->Q) {
            memset(s->X, 0, m->k * sizeof(double));            /* forced part; the free response is e^{At} z0 */
        } else {
            memcpy(s->X, m->z0, m->k * sizeof(double));
        }
        s->aux[0] = t_start;
        s->aux[1] = 0.0;
    }
    s->n = 0;
    s->time = t_start;
    s->f = 0.0;
    s->dt = m->dt;
    s->n_freeze = (int32_t)m->n_freeze_default;
}

RomStatus rom_set_start_time(RomState *s, double t_start, char *message, size_t message_size) {
    if (!s) return fail(message, message_size, "no state");
    if (!isfinite(t_start)) return fail(message, message_size, "start time %g is not finite", t_start);
    if (s->n != 0) return fail(message, message_size, "the start time can be set only before the first step");
    s->time = t_start;
    if (s->aux) s->aux[0] = t_start;
    return ROM_OK;
}

RomStatus rom_set_input(RomState *s, double f, char *message, size_t message_size) {
    if (!s) return fail(message, message_size, "no state");
    if (!isfinite(f)) {
        return fail(message, message_size, "input f = %g at t = %.9g s is not finite (allowed: a finite force per "
                    "mass in m s^-2)", f, s->time);
    }
    s->f = f;
    return ROM_OK;
}

RomStatus rom_set_input_rate(RomState *s, double rate, char *message, size_t message_size) {
    if (!s) return fail(message, message_size, "no state");
    if (!isfinite(rate)) {
        return fail(message, message_size, "input rate df/dt = %g at t = %.9g s is not finite", rate, s->time);
    }
    if (s->aux) s->aux[1] = rate;
    return ROM_OK;
}

size_t rom_reduced_state(const RomState *s, double *out, size_t n) {
    if (!s || !out) return 0;
    const size_t kv = s->model->k_v, kr = s->model->k_rho;
    if (n < kv + kr) return 0;
    memcpy(out, s->av, kv * sizeof(double));
    memcpy(out + kv, s->ar, kr * sizeof(double));
    return kv + kr;
}

int64_t rom_expm_count(const RomState *s) {
    return s ? s->n_expm : -1;
}

uint32_t rom_model_kind(const RomModel *m) {
    return m ? m->kind : 0u;
}

RomStatus rom_set_dt(RomState *s, double dt, char *message, size_t message_size) {
    if (!s) return fail(message, message_size, "no state");
    if (!(isfinite(dt) && dt > 0)) {
        return fail(message, message_size, "parameter dt = %g s is out of range (allowed: a finite number > 0)", dt);
    }
    s->dt = dt;
    return ROM_OK;
}

RomStatus rom_set_n_freeze(RomState *s, int64_t n_freeze, char *message, size_t message_size) {
    if (!s) return fail(message, message_size, "no state");
    if (n_freeze < 1 || n_freeze > INT32_MAX) {
        return fail(message, message_size, "parameter n_freeze = %lld is out of range (allowed: an integer >= 1)",
                    (long long)n_freeze);
    }
    s->n_freeze = (int32_t)n_freeze;
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* the step (harness/rom/frozen.py frozen_advance, same order of operations)  */
/* ------------------------------------------------------------------------ */

/* M(a^rho) = sum_{a<=b} a^rho_a a^rho_b T_ab (eq. 2.23 projected; exact) and
 * the frozen force term F = p f (eq. 2.19), every n_freeze steps.  Each entry
 * is 0.0 + s_0 T_0 + s_1 T_1 + ... in pair order, as in Python; the entries are
 * computed 32 at a time in registers. */
ROM_INLINE void refresh(RomState *s) {
    const RomModel *m = s->model;
    const size_t kr = m->k_rho, np = m->n_pairs, nm = m->nm;
    const double *restrict ar = s->ar;
    double *restrict S = s->S;
    size_t k = 0;
    for (size_t a = 0; a < kr; a++) {
        for (size_t b = a; b < kr; b++) S[k++] = ar[a] * ar[b];
    }
    double *restrict Mt = s->Mt;
    for (size_t i = 0; i < nm; i += 32) {
        double acc[32];
        for (int j = 0; j < 32; j++) acc[j] = 0.0;
        const double *restrict T = m->Tt + i * np;
        for (k = 0; k < np; k++, T += 32) {
            const double sk = S[k];
            for (int j = 0; j < 32; j++) acc[j] += sk * T[j];
        }
        for (int j = 0; j < 32; j++) Mt[i + j] = acc[j];
    }
    double *restrict F = s->F;
    const size_t kv = m->kv_pad;
    if (m->p) {
        for (size_t p = 0; p < kv; p++) F[p] = m->p[p] * s->f;
    } else {
        for (size_t p = 0; p < kv; p++) F[p] = 0.0;
    }
}

/* Blocks of 4 lanes: GCC/Clang vector extensions (one AVX2 register, two SSE2
 * registers), plain arrays elsewhere.  Every lane does the scalar IEEE
 * operation, in the same order. */
#if defined(__GNUC__)
typedef double v4d __attribute__((vector_size(32)));
#define V4_LOAD(ptr) (*(const v4d *)(const void *)(ptr))
#define V4_STORE(ptr, v) (*(v4d *)(void *)(ptr) = (v))
#define V4_ZERO ((v4d){0.0, 0.0, 0.0, 0.0})
#define V4_SPLAT(x) ((v4d){(x), (x), (x), (x)})
#endif

/* da^rho/dt = -M a^v (eq. 2.20 with frozen M): dr[p] = 0.0 - M[p][0] av[0] - ... */
ROM_INLINE void density_rate(const RomModel *m, double *restrict dr, const double *restrict av,
                             const double *restrict Mt) {
    const size_t krp = m->kr_pad, kv = m->k_v;
    for (size_t p = 0; p < krp; p += 4) {
        const double *restrict col = Mt + p;
#if defined(__GNUC__)
        v4d acc = V4_ZERO;
        for (size_t q = 0; q < kv; q++, col += krp) acc -= V4_LOAD(col) * V4_SPLAT(av[q]);
        V4_STORE(dr + p, acc);
#else
        double acc[4] = {0.0, 0.0, 0.0, 0.0};
        for (size_t q = 0; q < kv; q++, col += krp) {
            for (int j = 0; j < 4; j++) acc[j] -= col[j] * av[q];
        }
        for (int j = 0; j < 4; j++) dr[p + j] = acc[j];
#endif
    }
}

/* da^v/dt = b + F - K a^rho - D a^v (eq. 2.19 with frozen F) */
ROM_INLINE void velocity_rate(const RomModel *m, double *restrict dv, const double *restrict av,
                              const double *restrict ar, const double *restrict F) {
    const size_t kvp = m->kv_pad, kv = m->k_v, kr = m->k_rho;
    for (size_t p = 0; p < kvp; p += 4) {
        const double *restrict col = m->Kt + p;
#if defined(__GNUC__)
        v4d acc = V4_LOAD(m->b + p) + V4_LOAD(F + p);
        for (size_t q = 0; q < kr; q++, col += kvp) acc -= V4_LOAD(col) * V4_SPLAT(ar[q]);
        if (m->Dt) {
            col = m->Dt + p;
            for (size_t q = 0; q < kv; q++, col += kvp) acc -= V4_LOAD(col) * V4_SPLAT(av[q]);
        }
        V4_STORE(dv + p, acc);
#else
        double acc[4];
        for (int j = 0; j < 4; j++) acc[j] = m->b[p + j] + F[p + j];
        for (size_t q = 0; q < kr; q++, col += kvp) {
            for (int j = 0; j < 4; j++) acc[j] -= col[j] * ar[q];
        }
        if (m->Dt) {
            col = m->Dt + p;
            for (size_t q = 0; q < kv; q++, col += kvp) {
                for (int j = 0; j < 4; j++) acc[j] -= col[j] * av[q];
            }
        }
        for (int j = 0; j < 4; j++) dv[p + j] = acc[j];
#endif
    }
}

ROM_INLINE void axpy(double *restrict x, double h, const double *restrict y, size_t n) {
    for (size_t i = 0; i < n; i += 4) {
#if defined(__GNUC__)
        V4_STORE(x + i, V4_LOAD(x + i) + V4_SPLAT(h) * V4_LOAD(y + i));
#else
        for (int j = 0; j < 4; j++) x[i + j] += h * y[i + j];
#endif
    }
}

/* finite and |a| <= bound everywhere: one comparison per value (NaN fails it) */
ROM_INLINE int state_ok(const RomState *s) {
    const double bound = s->model->runaway_bound;
    int ok = 1;
    for (size_t i = 0; i < s->model->k_v; i++) ok &= (fabs(s->av[i]) <= bound);
    for (size_t i = 0; i < s->model->k_rho; i++) ok &= (fabs(s->ar[i]) <= bound);
    return ok;
}

static RomStatus state_failure(const RomState *s, double t, char *message, size_t message_size) {
    const int finite = all_finite(s->av, s->model->k_v) && all_finite(s->ar, s->model->k_rho);
    if (!finite) {
        return fail(message, message_size, "the reduced state became non-finite at t = %.9g s (internal step %lld)",
                    t, (long long)s->n);
    }
    return fail(message, message_size,
                "the reduced state ran away (|a| > %.3g) at t = %.9g s (internal step %lld)",
                s->model->runaway_bound, t, (long long)s->n);
}

/* count internal steps of length h; returns the number done before a failure
 * (count when all are fine).  Euler: both rates from the old state;
 * symplectic: a^rho first, then the velocity rate with the new a^rho. */
ROM_CLONES
static int64_t run_steps_kernel(RomState *s, int64_t count, double h) {
    const RomModel *m = s->model;
    const int64_t nf = s->n_freeze;
    int64_t phase = s->n % nf;
    const int symplectic = m->integrator == ROM_INTEGRATOR_SYMPLECTIC;
    double *restrict av = s->av;
    double *restrict ar = s->ar;
    double *restrict dv = s->dv;
    double *restrict dr = s->dr;
    for (int64_t j = 0; j < count; j++) {
        if (phase == 0) refresh(s);
        density_rate(m, dr, av, s->Mt);
        if (symplectic) {
            axpy(ar, h, dr, m->kr_pad);
            velocity_rate(m, dv, av, ar, s->F);
        } else {
            velocity_rate(m, dv, av, ar, s->F);
            axpy(ar, h, dr, m->kr_pad);
        }
        axpy(av, h, dv, m->kv_pad);
        s->n++;
        phase = (phase + 1 == nf) ? 0 : phase + 1;
        if (!state_ok(s)) return j + 1;
    }
    return count;
}

static RomStatus run_steps(RomState *s, int64_t count, double h, double t0, char *message, size_t message_size) {
    if (count <= 0) return ROM_OK;
    const int64_t done = run_steps_kernel(s, count, h);
    if (done < count || !state_ok(s)) return state_failure(s, t0 + (double)done * h, message, message_size);
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* the exact linear model (harness/rom/exact_linear.py)                      */
/* ------------------------------------------------------------------------ */

#define ROM_TAYLOR_DEGREE 16            /* ||X||_1 <= 1/2: remainder < 0.5^17/17! ~ 2e-20 */
#define ROM_TAYLOR_NORM 0.5
#define ROM_MAX_SQUARINGS 1100

static double norm1(size_t n, const double *M) {
    double best = 0.0;
    for (size_t j = 0; j < n; j++) {
        double sum = 0.0;
        for (size_t i = 0; i < n; i++) sum += fabs(M[i * n + j]);
        if (!(sum <= best)) best = sum;          /* NaN propagates */
    }
    return best;
}

static void matmul(size_t n, const double *restrict A, const double *restrict B, double *restrict C) {
    for (size_t i = 0; i < n * n; i++) C[i] = 0.0;
    for (size_t i = 0; i < n; i++) {
        for (size_t l = 0; l < n; l++) {
            const double a = A[i * n + l];
            if (a == 0.0) continue;
            const double *restrict row = B + l * n;
            double *restrict out = C + i * n;
            for (size_t j = 0; j < n; j++) out[j] += a * row[j];
        }
    }
}

/* E = e^M (n x n, row-major) by scaling and squaring with a Taylor polynomial
 * (Horner form) on M / 2^s, ||M / 2^s||_1 <= 1/2.  X, T: n x n scratch.
 * Returns 0 when M or the result is not finite. */
static int expm_taylor(size_t n, const double *M, double *E, double *X, double *T) {
    const double nrm = norm1(n, M);
    if (!isfinite(nrm)) return 0;
    int squarings = 0;
    if (nrm > ROM_TAYLOR_NORM) squarings = (int)ceil(log2(nrm / ROM_TAYLOR_NORM));
    if (squarings > ROM_MAX_SQUARINGS) return 0;
    const double scale = ldexp(1.0, -squarings);
    for (size_t i = 0; i < n * n; i++) X[i] = M[i] * scale;
    for (size_t i = 0; i < n * n; i++) E[i] = 0.0;
    for (size_t i = 0; i < n; i++) E[i * n + i] = 1.0;
    for (int j = ROM_TAYLOR_DEGREE; j >= 1; j--) {      /* E = I + X E / j */
        matmul(n, X, E, T);
        const double inv = 1.0 / (double)j;
        for (size_t i = 0; i < n * n; i++) E[i] = T[i] * inv;
        for (size_t i = 0; i < n; i++) E[i * n + i] += 1.0;
    }
    for (int q = 0; q < squarings; q++) {
        matmul(n, E, E, T);
        memcpy(E, T, n * n * sizeof(double));
    }
    return all_finite(E, n * n);
}

/* The maps of a step of length h: Phi = e^{A h}, G0, G1 from the exponential
 * of [[A h, B h, 0], [0, 0, 1], [0, 0, 0]] (as harness.rom.exact_linear.propagators),
 * cached per step length (two slots, the least recently used replaced). */
static RomExpCache *exact_maps(RomState *s, double h, char *message, size_t message_size) {
    const RomModel *m = s->model;
    s->clock++;
    for (int c = 0; c < ROM_EXACT_CACHE; c++) {
        if (s->cache[c].h == h) {
            s->cache[c].used = s->clock;
            return &s->cache[c];
        }
    }
    RomExpCache *slot = &s->cache[0];
    for (int c = 1; c < ROM_EXACT_CACHE; c++) {
        if (s->cache[c].used < slot->used) slot = &s->cache[c];
    }
    const size_t k = m->k, n = m->B ? k + 2 : k;
    double *M = s->work, *E = M + n * n, *X = E + n * n, *T = X + n * n;
    memset(M, 0, n * n * sizeof(double));
    for (size_t i = 0; i < k; i++) {
        for (size_t j = 0; j < k; j++) M[i * n + j] = m->A[i * k + j] * h;
        if (m->B) M[i * n + k] = m->B[i] * h;
    }
    if (m->B) M[k * n + k + 1] = 1.0;
    slot->h = 0.0;
    if (!expm_taylor(n, M, E, X, T)) {
        fail(message, message_size, "the matrix exponential for the step %g s is not finite (step too long for "
             "this model)", h);
        return NULL;
    }
    s->n_expm++;
    for (size_t i = 0; i < k; i++) {
        memcpy(slot->Phi + i * k, E + i * n, k * sizeof(double));
        slot->G0[i] = m->B ? E[i * n + k] : 0.0;
        slot->G1[i] = m->B ? E[i * n + k + 1] : 0.0;
    }
    slot->h = h;
    slot->used = s->clock;
    return slot;
}

/* z = e^{A t} z0 from the real Schur form A = Q S Q^T (skew A: S has 2x2
 * rotation blocks [[0, w], [-w, 0]] and zeros), evaluated at t directly. */
static void free_response(const RomModel *m, double t, double *restrict y, double *restrict z) {
    const size_t k = m->k;
    size_t i = 0;
    while (i < k) {
        if (i + 1 < k && m->S[(i + 1) * k + i] != 0.0) {
            const double w = m->S[i * k + i + 1];
            const double cs = cos(w * t), sn = sin(w * t);
            const double a = m->y0[i], b = m->y0[i + 1];
            y[i] = cs * a + sn * b;
            y[i + 1] = -sn * a + cs * b;
            i += 2;
        } else {
            y[i] = m->y0[i];
            i += 1;
        }
    }
    for (size_t r = 0; r < k; r++) {
        double acc = 0.0;
        const double *row = m->Q + r * k;
        for (size_t c = 0; c < k; c++) acc += row[c] * y[c];
        z[r] = acc;
    }
}

/* One exact step from t_comm over h: X <- Phi X + G0 f + G1 (rate h); z = free(t - t0) + X
 * (or X).  On failure the state keeps its last good values (the time stays t_comm). */
static RomStatus exact_step(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    const RomModel *m = s->model;
    const size_t k = m->k, kv = m->k_v;
    const RomExpCache *c = exact_maps(s, h, message, message_size);
    if (!c) return ROM_FAIL;
    const size_t n = m->B ? k + 2 : k;
    double *xn = s->work + 4 * n * n, *z = xn + k;
    const double f = s->f, df = s->aux[1] * h;
    for (size_t i = 0; i < k; i++) {
        double acc = 0.0;
        const double *row = c->Phi + i * k;
        for (size_t j = 0; j < k; j++) acc += row[j] * s->X[j];
        if (m->B) acc = acc + c->G0[i] * f + c->G1[i] * df;
        xn[i] = acc;
    }
    const double t_new = t_comm + h;
    if (m->Q) {
        double *y = s->work;             /* the exponential's scratch is free again */
        free_response(m, t_new - s->aux[0], y, z);
        for (size_t i = 0; i < k; i++) z[i] += xn[i];
    } else {
        memcpy(z, xn, k * sizeof(double));
    }
    const double bound = m->runaway_bound;
    int ok = 1;
    for (size_t i = 0; i < k; i++) ok &= (fabs(z[i]) <= bound);
    if (!ok) {
        return fail(message, message_size, "the exact reduced state %s at t = %.9g s (step %lld from t = %.9g s)",
                    all_finite(z, k) ? "ran away (|z| above its bound)" : "became non-finite", t_new,
                    (long long)s->n + 1, t_comm);
    }
    memcpy(s->X, xn, k * sizeof(double));
    memcpy(s->av, z, kv * sizeof(double));
    memcpy(s->ar, z + kv, m->k_rho * sizeof(double));
    s->n++;
    s->time = t_new;
    return ROM_OK;
}

RomStatus rom_do_step(RomState *s, double t_comm, double h, char *message, size_t message_size) {
    if (!s) return fail(message, message_size, "no state");
    if (!isfinite(t_comm)) {
        return fail(message, message_size, "currentCommunicationPoint = %g is not finite", t_comm);
    }
    if (fabs(t_comm - s->time) > ROM_TIME_TOLERANCE * fmax(1.0, fabs(s->time))) {
        return fail(message, message_size,
                    "currentCommunicationPoint = %.17g s does not match the FMU's time %.17g s", t_comm, s->time);
    }
    if (!(isfinite(h) && h > 0)) {
        return fail(message, message_size,
                    "communicationStepSize = %g s at t = %.9g s is out of range (allowed: a finite number > 0)",
                    h, t_comm);
    }
    if (s->model->kind == ROM_MODEL_EXACT_LINEAR) {
        /* one exact step over h whatever dt is: the input held (or linear) over it */
        if (s->n == INT64_MAX) return fail(message, message_size, "step counter overflow");
        const RomStatus status = exact_step(s, t_comm, h, message, message_size);
        if (status != ROM_OK) return status;
        s->time = t_comm + h;
        return rom_check_outputs(s, message, message_size);
    }
    const double dt = s->dt;
    const double ratio = h / dt;
    if (!(ratio < ROM_MAX_STEPS_PER_CALL) || s->n > INT64_MAX - (int64_t)ratio - 2) {
        return fail(message, message_size, "communicationStepSize = %g s at t = %.9g s is %g internal steps "
                    "(allowed: fewer than %g)", h, t_comm, ratio, ROM_MAX_STEPS_PER_CALL);
    }
    /* whole steps of dt, then one shortened step to reach t_comm + h exactly */
    const double nearest = floor(ratio + 0.5);
    int64_t n_full;
    double rest = 0.0;
    if (fabs(ratio - nearest) <= ROM_STEP_ROUNDING * fmax(1.0, ratio)) {
        n_full = (int64_t)nearest;
    } else {
        n_full = (int64_t)floor(ratio);
        rest = h - (double)n_full * dt;
    }
    RomStatus status = run_steps(s, n_full, dt, t_comm, message, message_size);
    if (status == ROM_OK && rest > ROM_SHORT_STEP_MIN * dt) {
        status = run_steps(s, 1, rest, t_comm + (double)n_full * dt, message, message_size);
    }
    if (status != ROM_OK) return status;     /* the instance is unusable; the message names the time */
    s->time = t_comm + h;
    return rom_check_outputs(s, message, message_size);
}

RomStatus rom_advance(RomState *s, int64_t n_steps, char *message, size_t message_size) {
    if (!s) return fail(message, message_size, "no state");
    if (n_steps < 0) return fail(message, message_size, "negative step count %lld", (long long)n_steps);
    if (s->model->kind == ROM_MODEL_EXACT_LINEAR) {
        for (int64_t j = 0; j < n_steps; j++) {
            if (exact_step(s, s->time, s->dt, message, message_size) != ROM_OK) return ROM_FAIL;
        }
        return ROM_OK;
    }
    const double t0 = s->time;
    const RomStatus status = run_steps(s, n_steps, s->dt, t0, message, message_size);
    s->time = t0 + (double)n_steps * s->dt;
    return status;
}

double rom_v_probe(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_probes) return NAN;
    const size_t kv = s->model->k_v;
    const double *row = s->model->Pv + (size_t)j * kv;
    double v = 0.0;
    for (size_t q = 0; q < kv; q++) v += row[q] * s->av[q];
    return v;
}

double rom_rho_probe(const RomState *s, uint32_t j) {
    if (!s || j >= s->model->n_probes) return NAN;
    const size_t kr = s->model->k_rho;
    if (s->model->kind == ROM_MODEL_EXACT_LINEAR) {      /* rho = rho0 / J, J = 1 + e at the two particles */
        const RomModel *m = s->model;
        double rho = 0.0;
        for (int side = 0; side < 2; side++) {
            const double *row = m->Pe + ((size_t)j * 2 + (size_t)side) * kr;
            double e = 0.0;
            for (size_t q = 0; q < kr; q++) e += row[q] * s->ar[q];
            const double J = 1.0 + e;
            if (!(J > 0)) return NAN;                     /* compressed through J = 0: no density */
            rho += m->pw[2 * j + side] * (m->prho0[2 * j + side] / J);
        }
        return rho;
    }
    const double *row = s->model->Prho + (size_t)j * kr;
    double rho = 0.0;
    for (size_t q = 0; q < kr; q++) rho += row[q] * s->ar[q];
    return rho;
}

RomStatus rom_check_outputs(const RomState *s, char *message, size_t message_size) {
    if (!s) return fail(message, message_size, "no state");
    for (uint32_t j = 0; j < s->model->n_probes; j++) {
        const double rho = rom_rho_probe(s, j);
        if (!(rho > 0) || !isfinite(rho)) {
            return fail(message, message_size, "density at probe %u (x/L = %g) is %g (must be > 0) at t = %.9g s",
                        j + 1, s->model->probe_x[j], rho, s->time);
        }
    }
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* serialized state                                                          */
/* ------------------------------------------------------------------------ */

/* the real entries of a^v, a^rho, M^T (k_v rows of k_rho, stride kr_pad) and F,
 * in the order they are serialized */
static void state_blocks(const RomModel *m, size_t rows[4], size_t cols[4], size_t strides[4]) {
    if (m->kind == ROM_MODEL_EXACT_LINEAR) {           /* a, b, the forced part X, (t0, input rate) */
        rows[0] = 1; cols[0] = m->k_v;   strides[0] = 0;
        rows[1] = 1; cols[1] = m->k_rho; strides[1] = 0;
        rows[2] = 1; cols[2] = m->k;     strides[2] = 0;
        rows[3] = 1; cols[3] = 2;        strides[3] = 0;
        return;
    }
    rows[0] = 1; cols[0] = m->k_v;   strides[0] = 0;
    rows[1] = 1; cols[1] = m->k_rho; strides[1] = 0;
    rows[2] = m->k_v; cols[2] = m->k_rho; strides[2] = m->kr_pad;
    rows[3] = 1; cols[3] = m->k_v;   strides[3] = 0;
}

static size_t state_doubles(const RomModel *m) {
    if (m->kind == ROM_MODEL_EXACT_LINEAR) return (size_t)m->k_v + m->k_rho + m->k + 2;
    return 2 * (size_t)m->k_v + m->k_rho + (size_t)m->k_rho * m->k_v;
}

size_t rom_state_serialized_size(const RomModel *m) {
    if (!m) return 0;
    return ROM_STATE_HEADER_SIZE + 8 * state_doubles(m) + 4;
}

void rom_state_serialize(const RomState *s, uint32_t tag, unsigned char *buffer) {
    if (!s || !buffer) return;
    const RomModel *m = s->model;
    const size_t size = rom_state_serialized_size(m);
    memset(buffer, 0, size);
    memcpy(buffer, STATE_MAGIC, 8);
    put_u32(buffer + 8, ROM_STATE_VERSION);
    put_u32(buffer + 12, tag);
    put_u32(buffer + 16, m->k_v);
    put_u32(buffer + 20, m->k_rho);
    put_u32(buffer + 24, m->n_probes);
    put_u32(buffer + 28, m->n_pairs);
    memcpy(buffer + 32, m->token, ROM_TOKEN_SIZE);
    put_u64(buffer + 72, (uint64_t)s->n);
    put_u32(buffer + 80, (uint32_t)s->n_freeze);
    put_u32(buffer + 84, 0);
    put_f64(buffer + 88, s->time);
    put_f64(buffer + 96, s->f);
    put_f64(buffer + 104, s->dt);
    unsigned char *cursor = buffer + ROM_STATE_HEADER_SIZE;
    const int exact = m->kind == ROM_MODEL_EXACT_LINEAR;
    const double *arrays[4] = {s->av, s->ar, exact ? s->X : s->Mt, exact ? s->aux : s->F};
    size_t rows[4], cols[4], strides[4];
    state_blocks(m, rows, cols, strides);
    for (int a = 0; a < 4; a++) {
        for (size_t r = 0; r < rows[a]; r++) {
            for (size_t c = 0; c < cols[a]; c++, cursor += 8) put_f64(cursor, arrays[a][r * strides[a] + c]);
        }
    }
    put_u32(cursor, rom_crc32(buffer, size - 4));
}

RomStatus rom_state_check(const RomModel *m, const unsigned char *buffer, size_t size, char *message,
                          size_t message_size) {
    if (!m || !buffer) return fail(message, message_size, "serialized state: no data");
    const size_t expected = rom_state_serialized_size(m);
    if (size < ROM_STATE_HEADER_SIZE || memcmp(buffer, STATE_MAGIC, 8) != 0) {
        return fail(message, message_size, "serialized state: not an sphrom FMU state (bad magic or too short)");
    }
    const uint32_t version = get_u32(buffer + 8);
    if (version != ROM_STATE_VERSION) {
        return fail(message, message_size, "serialized state: version %u is not supported (this binary reads %u)",
                    version, ROM_STATE_VERSION);
    }
    if (get_u32(buffer + 16) != m->k_v || get_u32(buffer + 20) != m->k_rho || get_u32(buffer + 24) != m->n_probes ||
        get_u32(buffer + 28) != m->n_pairs) {
        return fail(message, message_size,
                    "serialized state: sizes k_v = %u, k_rho = %u, %u probes do not match this FMU's %u, %u, %u "
                    "(a state from another FMU)", get_u32(buffer + 16), get_u32(buffer + 20), get_u32(buffer + 24),
                    m->k_v, m->k_rho, m->n_probes);
    }
    if (memcmp(buffer + 32, m->token, ROM_TOKEN_SIZE) != 0) {
        char other[ROM_TOKEN_SIZE + 1];
        memcpy(other, buffer + 32, ROM_TOKEN_SIZE);
        other[ROM_TOKEN_SIZE] = '\0';
        for (size_t i = 0; i < ROM_TOKEN_SIZE && other[i]; i++) {
            if (other[i] < 32 || other[i] > 126) other[i] = '?';
        }
        return fail(message, message_size, "serialized state: token %s is not this FMU's %s (a state from another "
                    "FMU)", other, m->token);
    }
    if (size != expected) {
        return fail(message, message_size, "serialized state: %zu bytes, expected %zu (truncated or corrupt)", size,
                    expected);
    }
    const uint32_t crc = rom_crc32(buffer, size - 4);
    if (crc != get_u32(buffer + size - 4)) {
        return fail(message, message_size, "serialized state: checksum mismatch (corrupt)");
    }
    const int64_t n = (int64_t)get_u64(buffer + 72);
    const int64_t n_freeze = (int32_t)get_u32(buffer + 80);
    const double time = get_f64(buffer + 88), f = get_f64(buffer + 96), dt = get_f64(buffer + 104);
    if (n < 0 || n_freeze < 1 || !isfinite(time) || !isfinite(f) || !(isfinite(dt) && dt > 0)) {
        return fail(message, message_size, "serialized state: invalid values (step %lld, n_freeze %lld, t %g, f %g, "
                    "dt %g)", (long long)n, (long long)n_freeze, time, f, dt);
    }
    const unsigned char *cursor = buffer + ROM_STATE_HEADER_SIZE;
    for (size_t i = 0; i < state_doubles(m); i++, cursor += 8) {
        if (!isfinite(get_f64(cursor))) {
            return fail(message, message_size, "serialized state: non-finite reduced state");
        }
    }
    return ROM_OK;
}

RomStatus rom_state_deserialize(RomState *s, const unsigned char *buffer, size_t size, uint32_t *tag, char *message,
                                size_t message_size) {
    if (!s) return fail(message, message_size, "no state");
    if (rom_state_check(s->model, buffer, size, message, message_size) != ROM_OK) return ROM_FAIL;
    const RomModel *m = s->model;
    if (tag) *tag = get_u32(buffer + 12);
    s->n = (int64_t)get_u64(buffer + 72);
    s->n_freeze = (int32_t)get_u32(buffer + 80);
    s->time = get_f64(buffer + 88);
    s->f = get_f64(buffer + 96);
    s->dt = get_f64(buffer + 104);
    const unsigned char *cursor = buffer + ROM_STATE_HEADER_SIZE;
    const int exact = m->kind == ROM_MODEL_EXACT_LINEAR;
    double *arrays[4] = {s->av, s->ar, exact ? s->X : s->Mt, exact ? s->aux : s->F};
    size_t rows[4], cols[4], strides[4];
    state_blocks(m, rows, cols, strides);
    for (int a = 0; a < 4; a++) {
        for (size_t r = 0; r < rows[a]; r++) {
            for (size_t c = 0; c < cols[a]; c++, cursor += 8) arrays[a][r * strides[a] + c] = get_f64(cursor);
        }
    }
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* helpers for the FMI glue                                                  */
/* ------------------------------------------------------------------------ */

static int hex_value(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

RomStatus rom_resource_file(const char *location, int is_uri, char *path, size_t path_size, char *message,
                            size_t message_size) {
    if (!path || path_size == 0) return fail(message, message_size, "no output buffer");
    path[0] = '\0';
    if (!location || !*location) {
        return fail(message, message_size, "no resource location given (the FMU needs its resources folder)");
    }
    const char *src = location;
    int decode = 0;
    if (is_uri && strncmp(location, "file:", 5) == 0) {
        src = location + 5;
        decode = 1;
        if (strncmp(src, "///", 3) == 0) {
            src += 2;                                   /* file:///path -> /path */
        } else if (strncmp(src, "//localhost/", 12) == 0) {
            src += 11;
        } else if (strncmp(src, "//", 2) == 0) {
            return fail(message, message_size, "resource location '%s': file URIs with a host are not supported",
                        location);
        }
#if defined(_WIN32)
        if (src[0] == '/' && src[1] && src[2] == ':') src += 1;   /* /C:/dir -> C:/dir */
#endif
    } else if (is_uri && strstr(location, "://")) {
        return fail(message, message_size, "resource location '%s' is not a file URI", location);
    }
    size_t n = 0;
    for (const char *c = src; *c; c++) {
        char out = *c;
        if (decode && *c == '%') {
            const int hi = hex_value(c[1]);
            const int lo = hi >= 0 ? hex_value(c[2]) : -1;
            if (hi < 0 || lo < 0 || (hi == 0 && lo == 0)) {
                return fail(message, message_size, "resource location '%s': bad percent escape", location);
            }
            out = (char)(hi * 16 + lo);
            c += 2;
        }
        if (n + 1 >= path_size) return fail(message, message_size, "resource location '%s' is too long", location);
        path[n++] = out;
    }
    if (n > 0 && path[n - 1] != '/' && path[n - 1] != '\\') {
        if (n + 1 >= path_size) return fail(message, message_size, "resource location '%s' is too long", location);
        path[n++] = '/';
    }
    const size_t name_length = strlen(ROM_RESOURCE_FILE);
    if (n + name_length + 1 > path_size) {
        return fail(message, message_size, "resource location '%s' is too long", location);
    }
    memcpy(path + n, ROM_RESOURCE_FILE, name_length + 1);
    return ROM_OK;
}

uint32_t rom_log_category(const char *name) {
    if (!name) return 0;
    if (strcmp(name, "logEvents") == 0) return ROM_LOG_EVENTS;
    if (strcmp(name, "logStatusWarning") == 0) return ROM_LOG_WARNING;
    if (strcmp(name, "logStatusError") == 0) return ROM_LOG_ERROR;
    return 0;
}

const char *rom_log_category_name(uint32_t bit) {
    switch (bit) {
        case ROM_LOG_EVENTS: return "logEvents";
        case ROM_LOG_WARNING: return "logStatusWarning";
        case ROM_LOG_ERROR: return "logStatusError";
        default: return "logStatusError";
    }
}
