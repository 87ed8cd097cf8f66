/*
 * Bytes in and out of the model core: resources/model.bin (the loader), the
 * serialized FMU state, zlib's CRC-32 and little-endian numbers.  Both formats
 * (rom.h) are read through one envelope check: size, magic, version, then the
 * caller's check of the header's sizes, then length, token and checksum.
 */
#include "rom_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>

#define ROM_MAX_FILE_SIZE ((size_t)1 << 30)    /* 1 GiB: far above any k <= 100 model */

/* ------------------------------------------------------------------------ */
/* little-endian numbers, CRC-32, token                                      */
/* ------------------------------------------------------------------------ */

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

/* ------------------------------------------------------------------------ */
/* the envelope shared by resources and serialized states                    */
/* ------------------------------------------------------------------------ */

typedef struct {
    const char *what;          /* the messages' subject */
    const char *magic;         /* 8 bytes */
    const char *contents;      /* what the magic announces */
    const char *empty;         /* what the smallest valid blob is */
    const char *one;           /* one such blob, in messages */
    const char *damaged;       /* what is truncated or corrupt when a check fails */
    uint32_t version;          /* the version written */
    size_t min_size;           /* bytes needed before the header can be read */
    uint32_t oldest;           /* the oldest version read */
} Envelope;

static const Envelope RESOURCES = {"resources", ROM_RESOURCE_MAGIC, "an sphrom model.bin", "an empty model",
                                   "a model", "file ", ROM_FORMAT_VERSION, ROM_HEADER_SIZE + ROM_TOKEN_SIZE + 4,
                                   ROM_FORMAT_VERSION};
static const Envelope STATE = {"serialized state", ROM_STATE_MAGIC, "an sphrom FMU state", "an empty state",
                               "a state", "", ROM_STATE_VERSION, ROM_STATE_HEADER_SIZE + 4,
                               ROM_STATE_VERSION_OLDEST};

/* Size, magic and version: then the header can be read */
static RomStatus envelope_open(const Envelope *e, const unsigned char *bytes, size_t size, char *message,
                               size_t message_size) {
    if (!bytes) return rom_fail(message, message_size, "%s: no data", e->what);
    if (size < e->min_size) {
        return rom_fail(message, message_size, "%s truncated: %zu bytes, fewer than the %zu of %s", e->what, size,
                        e->min_size, e->empty);
    }
    if (memcmp(bytes, e->magic, 8) != 0) {
        return rom_fail(message, message_size, "%s: bad magic (not %s)", e->what, e->contents);
    }
    const uint32_t version = get_u32(bytes + 8);
    if (version < e->oldest || version > e->version) {
        if (e->oldest == e->version) {
            return rom_fail(message, message_size, "%s: format version %u is not supported (this binary reads %u)",
                            e->what, version, e->version);
        }
        return rom_fail(message, message_size, "%s: format version %u is not supported (this binary reads %u to "
                        "%u)", e->what, version, e->oldest, e->version);
    }
    return ROM_OK;
}

/* Once the caller has checked the header's sizes: the token, when it must be a
 * given one (before the checksum, so that a blob from another FMU is named as
 * such), the length (detail says what it was computed for), the checksum of
 * every byte before the last four, and the token's form. */
static RomStatus envelope_close(const Envelope *e, const unsigned char *bytes, size_t size, uint64_t expected,
                                const char *detail, size_t token_offset, const char *token, char *message,
                                size_t message_size) {
    if (token && memcmp(bytes + token_offset, token, ROM_TOKEN_SIZE) != 0) {
        char other[ROM_TOKEN_SIZE + 1];
        memcpy(other, bytes + token_offset, ROM_TOKEN_SIZE);
        other[ROM_TOKEN_SIZE] = '\0';
        for (size_t i = 0; i < ROM_TOKEN_SIZE && other[i]; i++) {
            if (other[i] < 32 || other[i] > 126) other[i] = '?';
        }
        return rom_fail(message, message_size, "%s: token %s is not this FMU's %s (%s from another FMU)", e->what,
                        other, token, e->one);
    }
    if ((uint64_t)size != expected) {
        return rom_fail(message, message_size, "%s: %zu bytes, expected %llu%s (%struncated or corrupt)", e->what,
                        size, (unsigned long long)expected, detail, e->damaged);
    }
    const uint32_t stored = get_u32(bytes + size - 4), crc = rom_crc32(bytes, size - 4);
    if (crc != stored) {
        return rom_fail(message, message_size, "%s: checksum mismatch (stored 0x%08x, computed 0x%08x): %scorrupt",
                        e->what, stored, crc, e->damaged);
    }
    if (!valid_token((const char *)(bytes + token_offset))) {
        return rom_fail(message, message_size, "%s: the token field is not a GUID string", e->what);
    }
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* resources                                                                 */
/* ------------------------------------------------------------------------ */

typedef struct {
    uint32_t kind, integrator, k_v, k_rho, n_probes, n_pairs, flags, n_freeze, reserved;
    double dt, bound, L;
} Header;

/* the fields after magic and version, in the order of rom.h */
static Header read_header(const unsigned char *bytes) {
    Header h;
    uint32_t *const words[9] = {&h.kind, &h.integrator, &h.k_v, &h.k_rho, &h.n_probes, &h.n_pairs, &h.flags,
                                 &h.n_freeze, &h.reserved};
    double *const numbers[3] = {&h.dt, &h.bound, &h.L};
    const unsigned char *cursor = bytes + 12;
    for (int i = 0; i < 9; i++, cursor += 4) *words[i] = get_u32(cursor);
    for (int i = 0; i < 3; i++, cursor += 8) *numbers[i] = get_f64(cursor);
    return h;
}

/* The header's kind-specific rules; *doubles receives the count of float64 values after it. */
static RomStatus check_header(const Header *h, uint64_t *doubles, char *message, size_t message_size) {
    const int linear = rom_path(h->kind) == ROM_PATH_LINEAR;
    const char *second = linear ? "k_e" : "k_rho";
    const uint64_t kv = h->k_v, kr = h->k_rho, np = h->n_probes;
    if (linear && h->integrator != 0) {
        return rom_fail(message, message_size, "resources: integrator %u given for the exact model (must be 0: it "
                        "is advanced by the matrix exponential)", h->integrator);
    }
    if (!linear && h->integrator != ROM_INTEGRATOR_EULER && h->integrator != ROM_INTEGRATOR_SYMPLECTIC) {
        return rom_fail(message, message_size, "resources: integrator %u is not one of 0 (euler), 1 (symplectic)",
                        h->integrator);
    }
    /* with output rows over z the state need not split: k_e may be 0 (the balanced model's k_v = k) */
    const uint64_t kr_min = (linear && (h->flags & ROM_FLAG_OUTPUT_ROWS)) ? 0 : 1;
    if (kv < 1 || kv > ROM_MAX_MODES || kr < kr_min || kr > ROM_MAX_MODES) {
        return rom_fail(message, message_size, "resources: mode counts k_v = %u, %s = %u out of range [1, %u]%s",
                        h->k_v, second, h->k_rho, ROM_MAX_MODES, kr_min ? "" : " (k_e: [0, ...])");
    }
    if (np < 1 || np > ROM_MAX_PROBES) {
        return rom_fail(message, message_size, "resources: %u probes, out of range [1, %u]", h->n_probes,
                        ROM_MAX_PROBES);
    }
    if (linear && h->n_pairs != 0) {
        return rom_fail(message, message_size, "resources: n_pairs = %u, must be 0 for the exact model", h->n_pairs);
    }
    if (!linear && (uint64_t)h->n_pairs != kr * (kr + 1) / 2) {
        return rom_fail(message, message_size, "resources: n_pairs = %u, expected k_rho (k_rho + 1)/2 = %u",
                        h->n_pairs, h->k_rho * (h->k_rho + 1) / 2);
    }
    const uint32_t known = ROM_FLAG_DAMPING | ROM_FLAG_INPUT | (linear ? ROM_FLAG_SCHUR | ROM_FLAG_OUTPUT_ROWS : 0u);
    if (h->flags & ~known) return rom_fail(message, message_size, "resources: unknown flag bits 0x%x", h->flags);
    if ((h->flags & ROM_FLAG_SCHUR) && (h->flags & ROM_FLAG_DAMPING)) {
        return rom_fail(message, message_size, "resources: flag bits 0x%x: a Schur form with damping (the free "
                        "response by rotations needs a skew operator)", h->flags);
    }
    if (h->n_freeze < 1 || h->n_freeze > INT32_MAX || h->reserved != 0) {
        return rom_fail(message, message_size, "resources: n_freeze_default = %u (must be >= 1) or reserved = %u "
                        "(must be 0)", h->n_freeze, h->reserved);
    }
    const int damping = (h->flags & ROM_FLAG_DAMPING) != 0, input = (h->flags & ROM_FLAG_INPUT) != 0;
    if (linear) {               /* z0, A, B, Q, S, Pv, Pe, pw, prho0, probe_x */
        const uint64_t k = kv + kr, schur = (h->flags & ROM_FLAG_SCHUR) ? k * k : 0;
        const int rows = (h->flags & ROM_FLAG_OUTPUT_ROWS) != 0;       /* Pv, Pe over z, or over a, b */
        *doubles = k + k * k + (input ? k : 0) + 2 * schur + np * (rows ? k : kv) + np * 2 * (rows ? k : kr) +
                   4 * np + np;
    } else {                    /* a_v0, a_rho0, K, b, D, p, T, Pv, Prho, probe_x */
        *doubles = kv + kr + kv * kr + kv + (damping ? kv * kv : 0) + (input ? kv : 0) + h->n_pairs * kr * kv +
                   np * kv + np * kr + np;
    }
    return ROM_OK;
}

static void read_doubles(const unsigned char **cursor, double *out, uint64_t n) {
    for (uint64_t i = 0; i < n; i++) {
        out[i] = get_f64(*cursor);
        *cursor += 8;
    }
}

static int arrays_finite(double **ptrs[], const size_t *counts, int n) {
    int finite = 1;
    for (int i = 0; i < n; i++) finite &= !*ptrs[i] || rom_all_finite(*ptrs[i], counts[i]);
    return finite;
}

/* Frozen model: the operators transposed, zero-padded and blocked as rom.h's RomModel describes. */
static RomStatus read_frozen(RomModel *m, const unsigned char *cursor, uint64_t doubles, char *message,
                             size_t message_size) {
    const size_t kv = m->k_v, kr = m->k_rho, np = m->n_probes, npairs = m->n_pairs;
    m->kv_pad = (uint32_t)rom_round_up(kv, 4);
    m->kr_pad = (uint32_t)rom_round_up(kr, 4);
    m->nm = (uint32_t)rom_round_up(kv * m->kr_pad, 32);
    const size_t kvp = m->kv_pad, krp = m->kr_pad;
    const size_t counts[10] = {kv, kr, kr * kvp, kvp, (m->flags & ROM_FLAG_DAMPING) ? kv * kvp : 0,
                               (m->flags & ROM_FLAG_INPUT) ? kvp : 0, npairs * m->nm, np * kv, np * kr, np};
    double **ptrs[10] = {&m->a_v0, &m->a_rho0, &m->Kt, &m->b, &m->Dt, &m->p, &m->Tt, &m->Pv, &m->Prho, &m->probe_x};
    m->storage_ = rom_alloc_arrays(counts, ptrs, 10);
    if (!m->storage_) {
        return rom_fail(message, message_size, "resources: out of memory (%llu values)", (unsigned long long)doubles);
    }
    read_doubles(&cursor, m->a_v0, kv);
    read_doubles(&cursor, m->a_rho0, kr);
    for (size_t p = 0; p < kv; p++) {                    /* K[p][q] -> Kt[q*kv_pad + p] */
        for (size_t q = 0; q < kr; q++, cursor += 8) m->Kt[q * kvp + p] = get_f64(cursor);
    }
    read_doubles(&cursor, m->b, kv);
    if (m->Dt) {
        for (size_t p = 0; p < kv; p++) {
            for (size_t q = 0; q < kv; q++, cursor += 8) m->Dt[q * kvp + p] = get_f64(cursor);
        }
    }
    if (m->p) read_doubles(&cursor, m->p, kv);
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
    read_doubles(&cursor, m->Pv, np * kv);
    read_doubles(&cursor, m->Prho, np * kr);
    read_doubles(&cursor, m->probe_x, np);
    if (!arrays_finite(ptrs, counts, 10)) {
        return rom_fail(message, message_size, "resources: non-finite numbers in the operators");
    }
    for (uint32_t j = 0; j < np; j++) {
        const double x = m->probe_x[j];
        if (x < 0.0 || x > 1.0) {
            return rom_fail(message, message_size, "resources: probe %u at x/L = %g is outside [0, 1]", j + 1, x);
        }
    }
    return ROM_OK;
}

/* Exact linear model: the arrays as stored (row-major), a_v0 and a_rho0 pointing into z0. */
static RomStatus read_exact(RomModel *m, const unsigned char *cursor, uint64_t doubles, char *message,
                            size_t message_size) {
    const size_t kv = m->k_v, ke = m->k_rho, np = m->n_probes, k = (size_t)kv + ke;
    m->k = (uint32_t)k;
    m->kv_pad = (uint32_t)rom_round_up(kv, 4);
    m->kr_pad = (uint32_t)rom_round_up(ke, 4);
    m->nm = 0;
    const size_t cB = (m->flags & ROM_FLAG_INPUT) ? k : 0, cQ = (m->flags & ROM_FLAG_SCHUR) ? k * k : 0;
    const size_t counts[11] = {k, k * k, cB, cQ, cQ, cQ ? k : 0, np * k, np * 2 * k, 2 * np, 2 * np, np};
    double **ptrs[11] = {&m->z0, &m->A, &m->B, &m->Q, &m->S, &m->y0, &m->Pv, &m->Pe, &m->pw, &m->prho0,
                         &m->probe_x};
    m->storage_ = rom_alloc_arrays(counts, ptrs, 11);
    if (!m->storage_) {
        return rom_fail(message, message_size, "resources: out of memory (%llu values)", (unsigned long long)doubles);
    }
    read_doubles(&cursor, m->z0, k);
    read_doubles(&cursor, m->A, k * k);
    if (m->B) read_doubles(&cursor, m->B, k);
    if (m->Q) {
        read_doubles(&cursor, m->Q, k * k);
        read_doubles(&cursor, m->S, k * k);
    }
    if (m->flags & ROM_FLAG_OUTPUT_ROWS) {
        read_doubles(&cursor, m->Pv, np * k);
        read_doubles(&cursor, m->Pe, np * 2 * k);
    } else {                      /* rows over a (v) and over b (e), stored as rows over z = (a; b) */
        for (size_t j = 0; j < np; j++) read_doubles(&cursor, m->Pv + j * k, kv);
        for (size_t r = 0; r < 2 * np; r++) read_doubles(&cursor, m->Pe + r * k + kv, ke);
    }
    read_doubles(&cursor, m->pw, 2 * np);
    read_doubles(&cursor, m->prho0, 2 * np);
    read_doubles(&cursor, m->probe_x, np);
    m->a_v0 = m->z0;
    m->a_rho0 = m->z0 + kv;
    if (!arrays_finite(ptrs, counts, 11)) {
        return rom_fail(message, message_size, "resources: non-finite numbers in the operators");
    }
    for (uint32_t j = 0; j < np; j++) {
        const double x = m->probe_x[j], w0 = m->pw[2 * j], w1 = m->pw[2 * j + 1];
        if (x < 0.0 || x > 1.0 || w0 < 0.0 || w1 < 0.0 || fabs(w0 + w1 - 1.0) > 1e-12 || !(m->prho0[2 * j] > 0) ||
            !(m->prho0[2 * j + 1] > 0)) {
            return rom_fail(message, message_size, "resources: probe %u: x/L = %g outside [0, 1], or weights %g, "
                            "%g not a convex pair, or rho0 <= 0", j + 1, x, w0, w1);
        }
    }
    rom_exact_prepare(m);
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* tagged sections                                                           */
/* ------------------------------------------------------------------------ */

/* The tags this binary reads, each with the check of its shape against the
 * model (a feature that stores numbers in the resources adds one row here and
 * reads them with rom_model_section). */
typedef RomStatus (*SectionCheck)(const RomModel *m, const RomSection *s, char *message, size_t message_size);

typedef struct {
    const char *tag;
    const char *what;          /* what the section holds, in messages */
    SectionCheck check;        /* NULL: any shape */
} SectionRule;

/* BOUNDS: the certified error bounds of a linear model, 2 rows of n_probes: force_error_bound [s],
 * initial_state_error_bound [m s^-1 s^0.5] per probe (>= 0) */
static RomStatus check_bounds(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    if (!rom_is_linear(m) || s->rows != 2 || s->cols != m->n_probes) {
        return rom_fail(message, message_size, "resources: section 'BOUNDS' is %u x %u, expected 2 x %u (n_probes) "
                        "in a linear model", s->rows, s->cols, m->n_probes);
    }
    for (size_t i = 0; i < (size_t)s->rows * s->cols; i++) {
        if (!(s->data[i] >= 0)) {
            return rom_fail(message, message_size, "resources: section 'BOUNDS' holds %g (bounds are >= 0)",
                            s->data[i]);
        }
    }
    return ROM_OK;
}

/* LINMODEL: which linear model the matrices are (1 exact POD, 2 balanced), 1 x 1; for messages only */
static RomStatus check_linear_model(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    if (!rom_is_linear(m) || s->rows != 1 || s->cols != 1 ||
        !(s->data[0] == ROM_LINEAR_EXACT_POD || s->data[0] == ROM_LINEAR_BALANCED)) {
        return rom_fail(message, message_size, "resources: section 'LINMODEL' must be one value, %u (exact POD) or "
                        "%u (balanced), in a linear model", ROM_LINEAR_EXACT_POD, ROM_LINEAR_BALANCED);
    }
    return ROM_OK;
}

/* Parametric models (harness/rom/parametric.py): PARAMS (2 x 4: rows c, d; varied 0/1, start, min, max)
 * and the kind's affine pieces, each needing the other */
static RomStatus check_shape(const RomSection *s, uint32_t rows, uint32_t cols, char *message, size_t message_size) {
    if (s->rows == rows && s->cols == cols) return ROM_OK;
    return rom_fail(message, message_size, "resources: section '%s' is %u x %u, expected %u x %u", s->tag, s->rows,
                    s->cols, rows, cols);
}

static RomStatus check_params(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    if (check_shape(s, 2, 4, message, message_size) != ROM_OK) return ROM_FAIL;
    int varied = 0;
    for (int r = 0; r < 2; r++) {
        const double *row = s->data + 4 * r;
        if ((row[0] != 0.0 && row[0] != 1.0) || !(row[2] <= row[1] && row[1] <= row[3]) ||
            !(row[2] > 0.0 || (r == 1 && row[2] == 0.0))) {
            return rom_fail(message, message_size, "resources: section 'PARAMS' row %d: varied %g, start %g, range "
                            "[%g, %g] (expected 0 or 1 and min <= start <= max, c > 0, d >= 0)", r + 1, row[0], row[1],
                            row[2], row[3]);
        }
        varied |= row[0] != 0.0;
    }
    if (!varied) return rom_fail(message, message_size, "resources: section 'PARAMS' varies neither c nor d");
    static const char *const frozen[] = {"KC", "BC", NULL}, *const linear[] = {"A0", "AC", "AD", NULL};
    for (const char *const *tag = rom_is_linear(m) ? linear : frozen; *tag; tag++) {
        if (!rom_model_section(m, *tag)) {
            return rom_fail(message, message_size, "resources: section 'PARAMS' without section '%s'", *tag);
        }
    }
    const int damping = (m->flags & ROM_FLAG_DAMPING) != 0;
    if (!rom_is_linear(m) && damping != (rom_model_section(m, "DD") != NULL)) {
        return rom_fail(message, message_size, "resources: section 'DD' %s (it goes with the damping flag)",
                        damping ? "missing" : "without damping");
    }
    if (!rom_is_linear(m) && s->data[4] != 0.0 && !damping) {
        return rom_fail(message, message_size, "resources: d varies but the model has no damping term");
    }
    if (rom_is_linear(m) && (m->flags & ROM_FLAG_SCHUR)) {
        return rom_fail(message, message_size, "resources: a parametric linear model with a Schur form (A changes "
                        "with c and d)");
    }
    return ROM_OK;
}

static RomStatus check_affine(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    const int linear_tag = s->tag[0] == 'A';
    if (linear_tag != rom_is_linear(m)) {
        return rom_fail(message, message_size, "resources: section '%s' does not belong to a %s model", s->tag,
                        rom_is_linear(m) ? "linear" : "frozen");
    }
    if (!rom_model_section(m, "PARAMS")) {
        return rom_fail(message, message_size, "resources: section '%s' without section 'PARAMS'", s->tag);
    }
    if (linear_tag) return check_shape(s, m->k, m->k, message, message_size);
    if (strcmp(s->tag, "KC") == 0) return check_shape(s, m->k_v, m->k_rho, message, message_size);
    if (strcmp(s->tag, "BC") == 0) return check_shape(s, 1, m->k_v, message, message_size);
    return check_shape(s, m->k_v, m->k_v, message, message_size);
}

/* mechanical ports: PORTX (1 x P positions x/L in [0, 1)), PORTB (P rows over a^v, or over z for a linear
 * model), PORTC (P rows over a^v); all three or none (ports_prepare) */
static RomStatus check_port_x(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    (void)m;
    if (s->rows != 1 || s->cols < 1 || s->cols > ROM_MAX_PORTS) {
        return rom_fail(message, message_size, "resources: section 'PORTX' is %u x %u (allowed: 1 x 1 to 1 x %u "
                        "port positions)", s->rows, s->cols, ROM_MAX_PORTS);
    }
    for (uint32_t j = 0; j < s->cols; j++) {
        if (!(s->data[j] >= 0.0 && s->data[j] < 1.0)) {
            return rom_fail(message, message_size, "resources: port %u at x/L = %g (allowed: [0, 1))", j + 1,
                            s->data[j]);
        }
    }
    return ROM_OK;
}

static RomStatus check_port_rows(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    const RomSection *x = rom_model_section(m, "PORTX");
    const uint32_t cols = (strcmp(s->tag, "PORTB") == 0 && rom_is_linear(m)) ? m->k : m->k_v;
    if (!x) return rom_fail(message, message_size, "resources: section '%s' without 'PORTX'", s->tag);
    if (s->rows != x->cols || s->cols != cols) {
        return rom_fail(message, message_size, "resources: section '%s' is %u x %u, expected %u x %u (ports x "
                        "coordinates)", s->tag, s->rows, s->cols, x->cols, cols);
    }
    return ROM_OK;
}

static const SectionRule SECTION_RULES[] = {
    {"ENVELOPE", "the training envelope's scalars", rom_envelope_check_scalars},
    {"ENVRANGE", "the training envelope's coordinate ranges", rom_envelope_check_range},
    {"ENVPROBE", "rho0 at the probes (training envelope)", rom_envelope_check_probe},
    {"ENVPORT", "port coordinates at the end of each block (training envelope: not checked)",
     rom_envelope_check_ports},
    {"BOUNDS", "certified error bounds per probe (force, initial state)", check_bounds},
    {"LINMODEL", "which linear model: 1 exact POD, 2 balanced", check_linear_model},
    {"PARAMS", "parametric model: c and d (varied, start, min, max)", check_params},
    {"KC", "frozen model: K per unit c", check_affine},
    {"BC", "frozen model: b per unit c", check_affine},
    {"DD", "frozen model: D per unit d", check_affine},
    {"A0", "linear model: the part of A without c or d", check_affine},
    {"AC", "linear model: the part of A per unit c", check_affine},
    {"AD", "linear model: the part of A per unit d", check_affine},
    {"PORTX", "port positions x/L", check_port_x},
    {"PORTB", "port input rows (area 1)", check_port_rows},
    {"PORTC", "port velocity rows", check_port_rows},
    {NULL, NULL, NULL},        /* end of the table */
};

/* the model's ports from its sections: all three sections or none */
static RomStatus ports_prepare(RomModel *m, char *message, size_t message_size) {
    const RomSection *x = rom_model_section(m, "PORTX"), *b = rom_model_section(m, "PORTB"),
                     *c = rom_model_section(m, "PORTC");
    if (!x && !b && !c) return ROM_OK;
    if (!x || !b || !c) {
        return rom_fail(message, message_size, "resources: the port sections PORTX, PORTB, PORTC come together "
                        "(%s missing)", !x ? "PORTX" : (!b ? "PORTB" : "PORTC"));
    }
    m->n_ports = x->cols;
    m->port_x = x->data;
    m->port_B = b->data;
    m->port_C = c->data;
    return ROM_OK;
}

static const SectionRule *section_rule(const char *tag) {
    for (const SectionRule *r = SECTION_RULES; r->tag; r++) {
        if (strcmp(r->tag, tag) == 0) return r;
    }
    return NULL;
}

/* Walks the section headers from offset start: *count and *end (the offset
 * after the last section) for the length check; a header that runs past the
 * bytes before token and checksum makes *end exceed size, so that the length
 * check names the blob as truncated. */
static RomStatus scan_sections(const unsigned char *bytes, size_t size, uint64_t start, uint32_t *count,
                               uint64_t *end, char *message, size_t message_size) {
    const uint64_t limit = (uint64_t)size - ROM_TOKEN_SIZE - 4;
    *count = 0;
    *end = start + 4;
    if (start + 4 > limit) return ROM_OK;
    const uint32_t n = get_u32(bytes + start);
    if (n > ROM_MAX_SECTIONS) {
        return rom_fail(message, message_size, "resources: %u tagged sections, more than the %u allowed", n,
                        ROM_MAX_SECTIONS);
    }
    uint64_t cursor = start + 4;
    for (uint32_t i = 0; i < n; i++) {
        if (cursor + ROM_SECTION_TAG_SIZE + 8 > limit) {
            *end = cursor + ROM_SECTION_TAG_SIZE + 8;
            *count = n;
            return ROM_OK;
        }
        const uint64_t rows = get_u32(bytes + cursor + ROM_SECTION_TAG_SIZE);
        const uint64_t cols = get_u32(bytes + cursor + ROM_SECTION_TAG_SIZE + 4);
        if (rows * cols > ROM_MAX_SECTION_VALUES) {
            return rom_fail(message, message_size, "resources: section %u has %llu x %llu values, more than the %u "
                            "allowed", i + 1, (unsigned long long)rows, (unsigned long long)cols,
                            ROM_MAX_SECTION_VALUES);
        }
        cursor += ROM_SECTION_TAG_SIZE + 8 + 8 * rows * cols;
    }
    *count = n;
    *end = cursor;
    return ROM_OK;
}

/* Reads the n sections from offset start (the length is checked): tags known,
 * unique and well formed, data finite, shapes accepted by their rules. */
static RomStatus read_sections(RomModel *m, const unsigned char *bytes, uint64_t start, uint32_t n, char *message,
                               size_t message_size) {
    uint64_t cursor = start + 4, values = 0;
    for (uint32_t i = 0; i < n; i++) {
        RomSection *s = &m->sections[i];
        memcpy(s->tag, bytes + cursor, ROM_SECTION_TAG_SIZE);
        s->tag[ROM_SECTION_TAG_SIZE] = '\0';
        int ended = 0, printable = 1;
        for (int c = 0; c < ROM_SECTION_TAG_SIZE; c++) {
            const char ch = s->tag[c];
            if (ch == '\0') ended = 1;
            else if (ended || ch < 33 || ch > 126) printable = 0;
        }
        if (!printable || s->tag[0] == '\0') {
            return rom_fail(message, message_size, "resources: section %u: the tag is not NUL-padded printable "
                            "ASCII", i + 1);
        }
        const SectionRule *rule = section_rule(s->tag);
        if (!rule) {
            return rom_fail(message, message_size, "resources: section %u has the unknown tag '%s' (resources "
                            "written for a newer binary?)", i + 1, s->tag);
        }
        for (uint32_t j = 0; j < i; j++) {
            if (strcmp(m->sections[j].tag, s->tag) == 0) {
                return rom_fail(message, message_size, "resources: section '%s' appears twice", s->tag);
            }
        }
        s->rows = get_u32(bytes + cursor + ROM_SECTION_TAG_SIZE);
        s->cols = get_u32(bytes + cursor + ROM_SECTION_TAG_SIZE + 4);
        cursor += ROM_SECTION_TAG_SIZE + 8 + 8 * (uint64_t)s->rows * s->cols;
        values += (uint64_t)s->rows * s->cols;
    }
    m->n_sections = n;
    if (values > 0) {
        m->sections_storage_ = malloc((size_t)values * sizeof(double));
        if (!m->sections_storage_) {
            return rom_fail(message, message_size, "resources: out of memory (%llu section values)",
                            (unsigned long long)values);
        }
    }
    double *next = (double *)m->sections_storage_;
    cursor = start + 4;
    for (uint32_t i = 0; i < n; i++) {
        RomSection *s = &m->sections[i];
        const uint64_t count = (uint64_t)s->rows * s->cols;
        cursor += ROM_SECTION_TAG_SIZE + 8;
        s->data = count ? next : NULL;
        for (uint64_t v = 0; v < count; v++, cursor += 8) next[v] = get_f64(bytes + cursor);
        next += count;
        if (count && !rom_all_finite(s->data, (size_t)count)) {
            return rom_fail(message, message_size, "resources: non-finite numbers in section '%s'", s->tag);
        }
    }
    for (uint32_t i = 0; i < n; i++) {
        const SectionRule *rule = section_rule(m->sections[i].tag);
        if (rule->check && rule->check(m, &m->sections[i], message, message_size) != ROM_OK) return ROM_FAIL;
    }
    return ROM_OK;
}

const RomSection *rom_model_section(const RomModel *model, const char *tag) {
    if (!model || !tag) return NULL;
    for (uint32_t i = 0; i < model->n_sections; i++) {
        if (strcmp(model->sections[i].tag, tag) == 0) return &model->sections[i];
    }
    return NULL;
}

RomStatus rom_model_load_memory(const void *data, size_t size, RomModel **out, char *message, size_t message_size) {
    if (!out) return rom_fail(message, message_size, "resources: no output pointer");
    *out = NULL;
    const unsigned char *bytes = (const unsigned char *)data;
    if (envelope_open(&RESOURCES, bytes, size, message, message_size) != ROM_OK) return ROM_FAIL;
    const Header h = read_header(bytes);
    const RomPath path = rom_path(h.kind);
    if (path == ROM_PATH_NONE) {
        return rom_fail(message, message_size,
                        "resources: model kind %u is not supported by this binary (it runs kinds %u, the "
                        "frozen-coefficient model, and %u, the exact linear model)", h.kind, ROM_MODEL_FROZEN,
                        ROM_MODEL_EXACT_LINEAR);
    }
    uint64_t doubles = 0;
    if (check_header(&h, &doubles, message, message_size) != ROM_OK) return ROM_FAIL;
    const uint64_t sections_start = (uint64_t)ROM_HEADER_SIZE + 8u * doubles;
    uint32_t n_sections = 0;
    uint64_t sections_end = 0;
    if (scan_sections(bytes, size, sections_start, &n_sections, &sections_end, message, message_size) != ROM_OK) {
        return ROM_FAIL;
    }
    const uint64_t expected = sections_end + ROM_TOKEN_SIZE + 4u;
    char detail[160];
    snprintf(detail, sizeof detail, " for %sk_v = %u, %s = %u, %u probes, flags 0x%x, %u sections",
             path == ROM_PATH_LINEAR ? "the exact model with " : "", h.k_v, path == ROM_PATH_LINEAR ? "k_e" : "k_rho",
             h.k_rho, h.n_probes, h.flags, n_sections);
    const size_t token_offset = (size_t)(expected - 4 - ROM_TOKEN_SIZE);
    if (envelope_close(&RESOURCES, bytes, size, expected, detail, token_offset, NULL, message, message_size) !=
        ROM_OK) {
        return ROM_FAIL;
    }
    if (!(isfinite(h.dt) && h.dt > 0)) {
        return rom_fail(message, message_size, "resources: dt = %g (must be finite and > 0)", h.dt);
    }
    if (!(isfinite(h.bound) && h.bound > 0) || !(isfinite(h.L) && h.L > 0)) {
        return rom_fail(message, message_size, "resources: runaway bound %g and L %g must be finite and > 0", h.bound,
                        h.L);
    }
    RomModel *m = (RomModel *)calloc(1, sizeof(RomModel));
    if (!m) return rom_fail(message, message_size, "resources: out of memory");
    m->kind = h.kind;
    m->integrator = h.integrator;
    m->k_v = h.k_v;
    m->k_rho = h.k_rho;
    m->n_probes = h.n_probes;
    m->n_pairs = h.n_pairs;
    m->flags = h.flags;
    m->n_freeze_default = h.n_freeze;
    m->dt = h.dt;
    m->runaway_bound = h.bound;
    m->L = h.L;
    memcpy(m->token, bytes + token_offset, ROM_TOKEN_SIZE);
    m->token[ROM_TOKEN_SIZE] = '\0';
    const unsigned char *payload = bytes + ROM_HEADER_SIZE;
    RomStatus status = path == ROM_PATH_LINEAR ? read_exact(m, payload, doubles, message, message_size)
                                               : read_frozen(m, payload, doubles, message, message_size);
    if (status == ROM_OK) status = read_sections(m, bytes, sections_start, n_sections, message, message_size);
    if (status == ROM_OK) status = ports_prepare(m, message, message_size);
    if (status != ROM_OK) {
        rom_model_free(m);
        return ROM_FAIL;
    }
    *out = m;
    return ROM_OK;
}

RomStatus rom_model_load_file(const char *path, RomModel **out, char *message, size_t message_size) {
    if (!out) return rom_fail(message, message_size, "resources: no output pointer");
    *out = NULL;
    if (!path) return rom_fail(message, message_size, "resources: no path");
    errno = 0;
    FILE *file = fopen(path, "rb");
    if (!file) {
        const int err = errno;
        return rom_fail(message, message_size, "resources file '%s' %s", path,
                        err == ENOENT ? "not found" : err == EACCES ? "is not readable (permission denied)"
                                                                     : "cannot be opened");
    }
    unsigned char *buffer = NULL;
    size_t size = 0, capacity = 0;
    RomStatus status = ROM_OK;
    for (;;) {
        if (size == capacity) {
            if (capacity >= ROM_MAX_FILE_SIZE) {
                status = rom_fail(message, message_size, "resources file '%s' is larger than %zu bytes", path,
                                  ROM_MAX_FILE_SIZE);
                break;
            }
            const size_t grown = capacity ? 2 * capacity : 65536;
            unsigned char *bigger = (unsigned char *)realloc(buffer, grown);
            if (!bigger) {
                status = rom_fail(message, message_size, "resources file '%s': out of memory", path);
                break;
            }
            buffer = bigger;
            capacity = grown;
        }
        const size_t got = fread(buffer + size, 1, capacity - size, file);
        size += got;
        if (got == 0) {
            if (ferror(file)) status = rom_fail(message, message_size, "resources file '%s': read error", path);
            break;
        }
    }
    fclose(file);
    if (status == ROM_OK) {
        char inner[ROM_MESSAGE_SIZE];
        inner[0] = '\0';
        status = rom_model_load_memory(buffer, size, out, inner, sizeof inner);
        if (status != ROM_OK) rom_fail(message, message_size, "'%s': %s", path, inner);
    }
    free(buffer);
    return status;
}

void rom_model_free(RomModel *model) {
    if (!model) return;
    free(model->storage_);
    free(model->sections_storage_);
    free(model);
}

/* ------------------------------------------------------------------------ */
/* serialized state                                                          */
/* ------------------------------------------------------------------------ */

/* byte offsets of the state header's fields (rom.h) */
enum {
    ST_TAG = 12, ST_K_V = 16, ST_K_RHO = 20, ST_N_PROBES = 24, ST_N_PAIRS = 28, ST_TOKEN = 32,
    ST_N = 72, ST_N_FREEZE = 80, ST_RESERVED = 84, ST_TIME = 88, ST_F = 96, ST_DT = 104
};

/* The state's arrays in the order they are serialized: count rows of cols real
 * entries each, stride apart (frozen: a^v, a^rho, M^T (k_v rows of k_rho, stride
 * kr_pad), F and (t0, input rate); linear: a, b, the forced part X, (t0, input rate)).  The
 * parameters a state carries follow them (params_put, params_get). */
#define ROM_STATE_BLOCKS 5
typedef struct {
    double *data[ROM_STATE_BLOCKS];
    size_t rows[ROM_STATE_BLOCKS], cols[ROM_STATE_BLOCKS], strides[ROM_STATE_BLOCKS];
} StateBlocks;

static StateBlocks state_blocks(const RomState *s) {
    const RomModel *m = s->model;
    StateBlocks b;
    const int linear = rom_is_linear(m);
    double *third = linear ? s->X : s->Mt, *fourth = linear ? s->aux : s->F;
    const size_t sizes[ROM_STATE_BLOCKS][3] = {{1, m->k_v, 0}, {1, m->k_rho, 0},
                                {linear ? 1 : m->k_v, linear ? m->k : m->k_rho, linear ? 0 : m->kr_pad},
                                {1, linear ? 2 : m->k_v, 0}, {linear ? 0 : 1, 2, 0}};
    double *data[ROM_STATE_BLOCKS] = {s->av, s->ar, third, fourth, s->aux};
    for (int a = 0; a < ROM_STATE_BLOCKS; a++) {
        b.data[a] = data[a];
        b.rows[a] = sizes[a][0];
        b.cols[a] = sizes[a][1];
        b.strides[a] = sizes[a][2];
    }
    return b;
}

/* With ports, after the state's blocks: area, F_port[n_ports], port_driven (0 or 1; the slot was reserved and
 * written 0 before, so such a state reads as not driven), dF_port/dt[n_ports];
 * port_values(m) doubles, read or written at cursor (returns the cursor after them). */
static size_t port_values(const RomModel *m) {
    return m->n_ports ? 2 * (1 + (size_t)m->n_ports) : 0;
}

static unsigned char *ports_put(const RomState *s, unsigned char *cursor) {
    const size_t n = s->model->n_ports;
    if (!n) return cursor;
    put_f64(cursor, s->area);
    cursor += 8;
    for (size_t j = 0; j < n; j++, cursor += 8) put_f64(cursor, s->port_force[j]);
    put_f64(cursor, s->port_driven);
    cursor += 8;
    for (size_t j = 0; j < n; j++, cursor += 8) put_f64(cursor, s->port_rate[j]);
    return cursor;
}

static const unsigned char *ports_get(RomState *s, const unsigned char *cursor) {
    const size_t n = s->model->n_ports;
    if (!n) return cursor;
    s->area = get_f64(cursor);
    cursor += 8;
    for (size_t j = 0; j < n; j++, cursor += 8) s->port_force[j] = get_f64(cursor);
    s->port_driven = get_f64(cursor) != 0.0 ? 1.0 : 0.0;
    cursor += 8;
    for (size_t j = 0; j < n; j++, cursor += 8) s->port_rate[j] = get_f64(cursor);
    return cursor;
}

/* The parameters a state carries, after the kind's blocks: initial_state_scale, then (version 3) c, d */
static size_t param_values(uint32_t version) {
    return version >= 3 ? 3 : 1;
}

static unsigned char *params_put(const RomState *s, unsigned char *cursor) {
    const double values[3] = {s->initial_state_scale, s->c, s->d};
    for (size_t i = 0; i < param_values(ROM_STATE_VERSION); i++, cursor += 8) put_f64(cursor, values[i]);
    return cursor;
}

static const unsigned char *params_get(RomState *s, uint32_t version, const unsigned char *cursor) {
    double *const fields[3] = {&s->initial_state_scale, &s->c, &s->d};
    for (size_t i = 0; i < param_values(version); i++, cursor += 8) *fields[i] = get_f64(cursor);
    return cursor;
}

/* the kind's blocks (state_blocks), in doubles */
static size_t kind_doubles(const RomModel *m) {
    if (rom_is_linear(m)) return (size_t)m->k_v + m->k_rho + m->k + 2;
    return 2 * (size_t)m->k_v + m->k_rho + (size_t)m->k_rho * m->k_v + 2;
}

static size_t state_doubles(const RomModel *m, uint32_t version) {
    return kind_doubles(m) + param_values(version) + port_values(m);
}

size_t rom_state_serialized_size_version(const RomModel *m, uint32_t version) {
    if (!m || version < ROM_STATE_VERSION_OLDEST || version > ROM_STATE_VERSION) return 0;
    return ROM_STATE_HEADER_SIZE + 8 * state_doubles(m, version) + 4;
}

size_t rom_state_serialized_size(const RomModel *m) {
    return rom_state_serialized_size_version(m, ROM_STATE_VERSION);
}

void rom_state_serialize(const RomState *s, uint32_t tag, unsigned char *buffer) {
    if (!s || !buffer) return;
    const RomModel *m = s->model;
    const size_t size = rom_state_serialized_size(m);
    memset(buffer, 0, size);
    memcpy(buffer, ROM_STATE_MAGIC, 8);
    put_u32(buffer + 8, ROM_STATE_VERSION);
    put_u32(buffer + ST_TAG, tag);
    put_u32(buffer + ST_K_V, m->k_v);
    put_u32(buffer + ST_K_RHO, m->k_rho);
    put_u32(buffer + ST_N_PROBES, m->n_probes);
    put_u32(buffer + ST_N_PAIRS, m->n_pairs);
    memcpy(buffer + ST_TOKEN, m->token, ROM_TOKEN_SIZE);
    put_u64(buffer + ST_N, (uint64_t)s->n);
    put_u32(buffer + ST_N_FREEZE, (uint32_t)s->n_freeze);
    put_u32(buffer + ST_RESERVED, 0);
    put_f64(buffer + ST_TIME, s->time);
    put_f64(buffer + ST_F, s->f);
    put_f64(buffer + ST_DT, s->dt);
    unsigned char *cursor = buffer + ROM_STATE_HEADER_SIZE;
    const StateBlocks b = state_blocks(s);
    for (int a = 0; a < ROM_STATE_BLOCKS; a++) {
        for (size_t r = 0; r < b.rows[a]; r++) {
            for (size_t c = 0; c < b.cols[a]; c++, cursor += 8) put_f64(cursor, b.data[a][r * b.strides[a] + c]);
        }
    }
    cursor = params_put(s, cursor);
    cursor = ports_put(s, cursor);
    put_u32(cursor, rom_crc32(buffer, size - 4));
}

/* The parameters a state of this version carries (offset: the first after the kind's blocks), each named when
 * refused: initial_state_scale finite; c, d (version 3) inside a varied parameter's trained range, equal to the
 * model's value of a fixed one, 0 in a model without them; with ports the area finite and > 0. */
static RomStatus check_params_in_state(const RomModel *m, uint32_t version, const unsigned char *params,
                                       char *message, size_t message_size) {
    const double scale = get_f64(params);
    if (!isfinite(scale)) {
        return rom_fail(message, message_size, "serialized state: parameter initial_state_scale = %g is out of range "
                        "(allowed: a finite real number)", scale);
    }
    if (version >= 3) {
        const RomSection *section = rom_model_section(m, "PARAMS");
        for (int which = ROM_PARAM_C; which <= ROM_PARAM_D; which++) {
            const char *name = which == ROM_PARAM_C ? "c" : "d";
            const double value = get_f64(params + 8 * (1 + which));
            if (!section) {
                if (value != 0.0) {
                    return rom_fail(message, message_size, "serialized state: parameter %s = %g, but this FMU has "
                                    "no parameter %s (expected 0)", name, value, name);
                }
                continue;
            }
            const double *row = section->data + 4 * which;
            if (row[0] == 0.0 && !(value == row[1])) {
                return rom_fail(message, message_size, "serialized state: parameter %s = %g, but this FMU's %s is "
                                "fixed at %g", name, value, name, row[1]);
            }
            if (!(isfinite(value) && value >= row[2] && value <= row[3])) {
                return rom_fail(message, message_size, "serialized state: parameter %s = %g is outside the trained "
                                "range [%g, %g]", name, value, row[2], row[3]);
            }
        }
    }
    if (m->n_ports) {                  /* the area: the first value after the parameters */
        const double area = get_f64(params + 8 * param_values(version));
        if (!(isfinite(area) && area > 0)) {
            return rom_fail(message, message_size, "serialized state: parameter area = %g m^2 is out of range "
                            "(allowed: a finite number > 0)", area);
        }
    }
    return ROM_OK;
}

RomStatus rom_state_check(const RomModel *m, const unsigned char *buffer, size_t size, char *message,
                          size_t message_size) {
    if (!m) return rom_fail(message, message_size, "serialized state: no data");
    if (envelope_open(&STATE, buffer, size, message, message_size) != ROM_OK) return ROM_FAIL;
    const uint32_t version = get_u32(buffer + 8);
    static const struct { const char *field; size_t offset; } SIZES[4] = {
        {"k_v", ST_K_V}, {"k_rho", ST_K_RHO}, {"n_probes", ST_N_PROBES}, {"n_pairs", ST_N_PAIRS}};
    const uint32_t mine[4] = {m->k_v, m->k_rho, m->n_probes, m->n_pairs};
    for (int i = 0; i < 4; i++) {
        const uint32_t theirs = get_u32(buffer + SIZES[i].offset);
        if (theirs != mine[i]) {
            return rom_fail(message, message_size, "serialized state: %s is %u in the state, %u in this FMU (a state "
                            "from another FMU)", SIZES[i].field, theirs, mine[i]);
        }
    }
    char detail[48];
    snprintf(detail, sizeof detail, " for state version %u", version);
    if (envelope_close(&STATE, buffer, size, rom_state_serialized_size_version(m, version),
                       version == ROM_STATE_VERSION ? "" : detail, ST_TOKEN, m->token, message,
                       message_size) != ROM_OK) {
        return ROM_FAIL;
    }
    const int64_t n = (int64_t)get_u64(buffer + ST_N);
    const int64_t n_freeze = (int32_t)get_u32(buffer + ST_N_FREEZE);
    const double time = get_f64(buffer + ST_TIME), f = get_f64(buffer + ST_F), dt = get_f64(buffer + ST_DT);
    if (n < 0 || n_freeze < 1 || !isfinite(time) || !isfinite(f) || !(isfinite(dt) && dt > 0)) {
        return rom_fail(message, message_size, "serialized state: invalid values (step %lld, n_freeze %lld, t %g, "
                        "f %g, dt %g)", (long long)n, (long long)n_freeze, time, f, dt);
    }
    const unsigned char *params = buffer + ROM_STATE_HEADER_SIZE + 8 * kind_doubles(m);
    if (check_params_in_state(m, version, params, message, message_size) != ROM_OK) return ROM_FAIL;
    const unsigned char *cursor = buffer + ROM_STATE_HEADER_SIZE;
    for (size_t i = 0; i < state_doubles(m, version); i++, cursor += 8) {
        if (!isfinite(get_f64(cursor))) {
            return rom_fail(message, message_size, "serialized state: non-finite reduced state");
        }
    }
    return ROM_OK;
}

RomStatus rom_state_deserialize(RomState *s, const unsigned char *buffer, size_t size, uint32_t *tag, char *message,
                                size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (rom_state_check(s->model, buffer, size, message, message_size) != ROM_OK) return ROM_FAIL;
    if (tag) *tag = get_u32(buffer + ST_TAG);
    s->n = (int64_t)get_u64(buffer + ST_N);
    s->n_freeze = (int32_t)get_u32(buffer + ST_N_FREEZE);
    s->time = get_f64(buffer + ST_TIME);
    s->f = get_f64(buffer + ST_F);
    s->dt = get_f64(buffer + ST_DT);
    const unsigned char *cursor = buffer + ROM_STATE_HEADER_SIZE;
    const StateBlocks b = state_blocks(s);
    for (int a = 0; a < ROM_STATE_BLOCKS; a++) {
        for (size_t r = 0; r < b.rows[a]; r++) {
            for (size_t c = 0; c < b.cols[a]; c++, cursor += 8) b.data[a][r * b.strides[a] + c] = get_f64(cursor);
        }
    }
    cursor = params_get(s, get_u32(buffer + 8), cursor);
    (void)ports_get(s, cursor);
    return ROM_OK;
}
