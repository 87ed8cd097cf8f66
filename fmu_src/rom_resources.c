/*
 * resources/model.bin (rom.h's format): the header, the tagged sections and
 * the loader.  The header's model_kind chooses the kind's table of operations
 * (kind_ops: the one place that maps a kind number to a table); the kind's
 * rules on the header, its body and its own sections are asked of that table.
 * The envelope check (size, magic, version, length, token, checksum) is
 * rom_bytes.c's, shared with the serialized state.
 */
#include "rom_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>

#define ROM_MAX_FILE_SIZE ((size_t)1 << 30)    /* 1 GiB: far above any k <= 100 model */

static const RomBlob RESOURCES = {"resources", ROM_RESOURCE_MAGIC, "an sphrom model.bin", "an empty model",
                                  "a model", "file ", ROM_FORMAT_VERSION, ROM_FORMAT_VERSION,
                                  ROM_HEADER_SIZE + ROM_TOKEN_SIZE + 4,
                                  "; the file was written by an older sphrom: package the FMU again"};

/* ------------------------------------------------------------------------ */
/* the model kinds                                                           */
/* ------------------------------------------------------------------------ */

/* the kinds this binary runs, in the order the messages name them */
typedef const RomKindOps *(*KindTable)(void);
#define ROM_KIND_ENTRY(table) table,
static const KindTable KINDS[] = {ROM_KIND_TABLES(ROM_KIND_ENTRY)};     /* rom_layout.h, from layout.py KINDS */
#undef ROM_KIND_ENTRY
#define N_KINDS (sizeof KINDS / sizeof KINDS[0])

/* the table of the header's model_kind, NULL for a kind this binary does not run */
static const RomKindOps *kind_ops(uint32_t kind) {
    for (size_t i = 0; i < N_KINDS; i++) {
        if (KINDS[i]()->kind == kind) return KINDS[i]();
    }
    return NULL;
}

/* The message naming the kinds this binary runs: "... (it runs kinds 1, the ..., and 2, the ...)" */
static RomStatus unsupported_kind(uint32_t kind, char *message, size_t message_size) {
    char runs[256];
    size_t used = 0;
    runs[0] = '\0';
    for (size_t i = 0; i < N_KINDS && used < sizeof runs; i++) {
        const char *separator = i == 0 ? "" : (i + 1 == N_KINDS ? ", and " : ", ");
        const int n = snprintf(runs + used, sizeof runs - used, "%s%u, %s", separator, KINDS[i]()->kind,
                               KINDS[i]()->name);
        if (n < 0) break;
        used += (size_t)n;
    }
    return rom_fail(message, message_size, "resources: model kind %u is not supported by this binary (it runs kinds "
                    "%s)", kind, runs);
}

/* ------------------------------------------------------------------------ */
/* the header                                                                */
/* ------------------------------------------------------------------------ */

/* the shared header's fields after magic and version (rom_layout.h ROM_HEADER_*) */
static RomHeader read_header(const unsigned char *bytes) {
    RomHeader h;
    h.kind = rom_get_u32(bytes + ROM_HEADER_MODEL_KIND);
    h.k_v = rom_get_u32(bytes + ROM_HEADER_K_V);
    h.k_rho = rom_get_u32(bytes + ROM_HEADER_K_RHO);
    h.n_probes = rom_get_u32(bytes + ROM_HEADER_N_PROBES);
    h.flags = rom_get_u32(bytes + ROM_HEADER_FLAGS);
    h.bound = rom_get_f64(bytes + ROM_HEADER_RUNAWAY_BOUND);
    h.L = rom_get_f64(bytes + ROM_HEADER_L);
    return h;
}

/* The shared header's rules (sizes, flags), the kind's among them. */
static RomStatus check_header(const RomKindOps *kind, const RomHeader *h, char *message, size_t message_size) {
    const uint64_t kv = h->k_v, kr = h->k_rho, np = h->n_probes;
    const uint64_t kr_min = kind->min_k_rho(h);
    if (kv < 1 || kv > ROM_MAX_MODES || kr < kr_min || kr > ROM_MAX_MODES) {
        return rom_fail(message, message_size, "resources: mode counts k_v = %u, %s = %u out of range [1, %u]%s",
                        h->k_v, kind->k_rho_name, h->k_rho, ROM_MAX_MODES, kr_min ? "" : " (k_e: [0, ...])");
    }
    if (np < 1 || np > ROM_MAX_PROBES) {
        return rom_fail(message, message_size, "resources: %u probes, out of range [1, %u]", h->n_probes,
                        ROM_MAX_PROBES);
    }
    if (h->flags & ~kind->flags) return rom_fail(message, message_size, "resources: unknown flag bits 0x%x", h->flags);
    if ((h->flags & ROM_FLAG_SCHUR) && (h->flags & ROM_FLAG_DAMPING)) {
        return rom_fail(message, message_size, "resources: flag bits 0x%x: a Schur form with damping (the free "
                        "response by rotations needs a skew operator)", h->flags);
    }
    return ROM_OK;
}

/* ------------------------------------------------------------------------ */
/* tagged sections                                                           */
/* ------------------------------------------------------------------------ */

/* The tags this binary reads, each with the check of its shape against the
 * model (a feature that stores numbers in the resources adds one row here and
 * reads them with rom_model_section).  A tag that only some kinds read is in
 * their table's sections; in a model of another kind its check refuses it. */
typedef RomStatus (*SectionCheck)(const RomModel *m, const RomSection *s, char *message, size_t message_size);

typedef struct {
    const char *tag;
    const char *what;          /* what the section holds, in messages */
    SectionCheck check;        /* NULL: any shape */
} SectionRule;

/* 1 when the model's kind reads the section tag (its table's sections) */
static int kind_reads(const RomModel *m, const char *tag) {
    for (const char *const *t = m->ops->sections; *t; t++) {
        if (strcmp(*t, tag) == 0) return 1;
    }
    return 0;
}

/* BOUNDS: the certified error bounds of a linear model, 2 rows of n_probes: force_error_bound [s],
 * initial_state_error_bound [m s^-1 s^0.5] per probe (>= 0) */
static RomStatus check_bounds(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    if (!kind_reads(m, s->tag) || s->rows != 2 || s->cols != m->n_probes) {
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
    if (!kind_reads(m, s->tag) || s->rows != 1 || s->cols != ROM_LINMODEL_COLUMNS ||
        !(s->data[ROM_LINMODEL_MODEL] == ROM_LINEAR_EXACT_POD || s->data[ROM_LINMODEL_MODEL] == ROM_LINEAR_BALANCED)) {
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
    if (check_shape(s, 2, ROM_PARAMS_COLUMNS, message, message_size) != ROM_OK) return ROM_FAIL;
    int varied = 0;
    for (int r = ROM_PARAMS_ROW_C; r <= ROM_PARAMS_ROW_D; r++) {
        const double *row = s->data + ROM_PARAMS_COLUMNS * r;
        const double on = row[ROM_PARAMS_VARIED], start = row[ROM_PARAMS_START];
        const double lo = row[ROM_PARAMS_MIN], hi = row[ROM_PARAMS_MAX];
        if ((on != 0.0 && on != 1.0) || !(lo <= start && start <= hi) ||
            !(lo > 0.0 || (r == ROM_PARAMS_ROW_D && lo == 0.0))) {
            return rom_fail(message, message_size, "resources: section 'PARAMS' row %d: varied %g, start %g, range "
                            "[%g, %g] (expected 0 or 1 and min <= start <= max, c > 0, d >= 0)", r + 1, on, start,
                            lo, hi);
        }
        varied |= on != 0.0;
    }
    if (!varied) return rom_fail(message, message_size, "resources: section 'PARAMS' varies neither c nor d");
    for (const char *const *tag = m->ops->param_sections; *tag; tag++) {
        if (!rom_section(m, *tag)) {
            return rom_fail(message, message_size, "resources: section 'PARAMS' without section '%s'", *tag);
        }
    }
    return m->ops->check_params(m, s, message, message_size);
}

static RomStatus check_affine(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    if (!kind_reads(m, s->tag)) {
        return rom_fail(message, message_size, "resources: section '%s' does not belong to a %s model", s->tag,
                        m->ops->short_name);
    }
    if (!rom_section(m, "PARAMS")) {
        return rom_fail(message, message_size, "resources: section '%s' without section 'PARAMS'", s->tag);
    }
    uint32_t rows = 0, cols = 0;
    m->ops->affine_shape(m, s->tag, &rows, &cols);
    return check_shape(s, rows, cols, message, message_size);
}

/* the frozen model's particle refresh: PARTUR (N x k_rho), PARTGUV (N x k_v), PARTIR0 (1 x N, > 0), N from
 * PARTIR0; all three or none (rom_frozen.c frozen_sections_ready) */
static RomStatus check_particles(const RomModel *m, const RomSection *s, char *message, size_t message_size) {
    if (!kind_reads(m, s->tag)) {
        return rom_fail(message, message_size, "resources: section '%s' does not belong to a %s model", s->tag,
                        m->ops->short_name);
    }
    const RomSection *ir = rom_section(m, "PARTIR0");
    if (!ir || ir->rows != 1 || ir->cols < 1 || ir->cols > ROM_MAX_PARTICLES) {
        return rom_fail(message, message_size, "resources: section '%s' needs 'PARTIR0' of 1 x N, N from 1 to %u",
                        s->tag, ROM_MAX_PARTICLES);
    }
    const uint32_t n = ir->cols;
    if (strcmp(s->tag, "PARTUR") == 0) return check_shape(s, n, m->k_rho, message, message_size);
    if (strcmp(s->tag, "PARTGUV") == 0) return check_shape(s, n, m->k_v, message, message_size);
    for (uint32_t i = 0; i < n; i++) {
        if (!(s->data[i] > 0)) {
            return rom_fail(message, message_size, "resources: section 'PARTIR0' holds %g (1/rho0 is > 0)",
                            s->data[i]);
        }
    }
    return ROM_OK;
}

/* mechanical ports: PORTX (1 x P positions x/L in [0, 1)), PORTB (P input rows of the kind's input_width:
 * over a^v, or over z for a linear model), PORTC (P rows over a^v); all three or none (ports_prepare) */
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
    const RomSection *x = rom_section(m, "PORTX");
    /* PORTC: over a^v, or over the whole state of a linear model with output rows (k_v + k_e) */
    const uint32_t cols = strcmp(s->tag, "PORTB") == 0 ? m->input_width
                          : m->k_v + ((m->flags & ROM_FLAG_OUTPUT_ROWS) ? m->k_rho : 0u);
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
    {"ENVPROBE", "rho0 and the training run's max |v| at the probes (training envelope)", rom_envelope_check_probe},
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
    {"PARTUR", "frozen model: U^rho at the particles (the particle refresh)", check_particles},
    {"PARTGUV", "frozen model: G U^v at the particles (the particle refresh)", check_particles},
    {"PARTIR0", "frozen model: 1/rho0 at the particles (the particle refresh)", check_particles},
    {"PORTX", "port positions x/L", check_port_x},
    {"PORTB", "port input rows (area 1)", check_port_rows},
    {"PORTC", "port velocity rows", check_port_rows},
    {"SHSCAL", "error bounds: the shadow's sizes and scalars", rom_bound_check_section},
    {"SHLAM", "error bounds: the shadow's planes", rom_bound_check_section},
    {"SHB", "error bounds: the shadow's input columns", rom_bound_check_section},
    {"SHC", "error bounds: the shadow's output rows", rom_bound_check_section},
    {"SHW0", "error bounds: the shadow's initial state", rom_bound_check_section},
    {"SHROW", "error bounds: per output row, its norm, feedthrough, gains and tail", rom_bound_check_section},
    {"SHRATE", "error bounds: the complement's decay rates", rom_bound_check_section},
    {"SHPROBE", "error bounds: the probes' weights and rho0", rom_bound_check_section},
    {"SHTAB", "error bounds: the complement's free response and its slope at the table's nodes",
     rom_bound_check_section},
    {"SHTERR", "error bounds: the free response table's error per block of intervals", rom_bound_check_section},
    {"SHCONT", "error bounds: the complement's modes continued past the table (exponents, then amplitudes)",
     rom_bound_check_section},
    {"SHPIECE", "error bounds: the planes' pieces per unit c and per unit d", rom_bound_check_section},
    {"SHPARAM", "error bounds: c_ref and the residual pieces' norms", rom_bound_check_section},
    {"SHCPL", "error bounds: the complement's planes (parametric)", rom_bound_check_section},
    {"PCSCAL", "port channel: its sizes and scalars", rom_channel_check_section},
    {"PCLAM", "port channel: each plane's block", rom_channel_check_section},
    {"PCB", "port channel: each plane's input gains", rom_channel_check_section},
    {"PCC", "port channel: the output rows over the planes", rom_channel_check_section},
    {"PCD", "port channel: the static correction and the bound's gains", rom_channel_check_section},
    {"PCPROBE", "port channel: the probes' weights and rho0", rom_channel_check_section},
    {NULL, NULL, NULL},        /* end of the table */
};
/* one rule per tag of the layout (harness/fmu/layout.py SECTIONS; tests/test_fmu_constants.py compares the tags) */
typedef char section_rules_cover_the_layout[sizeof SECTION_RULES / sizeof SECTION_RULES[0] == ROM_N_SECTION_TAGS + 1
                                            ? 1 : -1];

/* ------------------------------------------------------------------------ */
/* the sections' value rules (rom_layout.h, from harness/fmu/layout.py)      */
/* ------------------------------------------------------------------------ */

/* Each rule of harness/fmu/layout.py SECTIONS' values, generated into rom_layout.h: the signs and ranges the code
 * reading a section relies on (a certified bound is >= 0 only if the norms it adds are), checked as soon as the sections
 * are read, before any use (a file edited after packaging with its checksum recomputed is refused naming the section, the place,
 * the value and the rule).  Columns [first, end) are c + i x inputs, the shadow's inputs (1 + ports, or 1
 * where SHSCAL says so); end c < 0: to the last column. */
typedef struct {
    const char *tag;
    int first_c, first_i, end_c, end_i;
    double low, high;
    int low_open, high_open, has_also;
    double also;
    const char *what, *allowed;
} RangeRule;
typedef struct {
    const char *tag;
    int first_c, first_i, end_c, end_i;
    double total, tolerance;
    const char *what;
} RowSumRule;

#define RANGE_ROW(tag, c0, i0, c1, i1, low, high, lo_open, hi_open, has_also, also, what, allowed) \
    {tag, c0, i0, c1, i1, low, high, lo_open, hi_open, has_also, also, what, allowed},
#define SUM_ROW(tag, c0, i0, c1, i1, total, tolerance, what) {tag, c0, i0, c1, i1, total, tolerance, what},
static const RangeRule RANGE_RULES[] = {ROM_RANGE_RULES(RANGE_ROW)};
static const RowSumRule ROW_SUM_RULES[] = {ROM_ROW_SUM_RULES(SUM_ROW)};
#undef RANGE_ROW
#undef SUM_ROW
#define N_RULES(table) (sizeof table / sizeof table[0])

/* the column span [*first, *end) of a rule in a section of cols columns */
static void rule_columns(int first_c, int first_i, int end_c, int end_i, uint32_t inputs, uint32_t cols,
                         uint32_t *first, uint32_t *end) {
    const int64_t a = (int64_t)first_c + (int64_t)first_i * inputs;
    const int64_t b = end_c < 0 ? (int64_t)cols : (int64_t)end_c + (int64_t)end_i * inputs;
    *first = a < 0 ? 0u : (a > (int64_t)cols ? cols : (uint32_t)a);
    *end = b < (int64_t)*first ? *first : (b > (int64_t)cols ? cols : (uint32_t)b);
}

static RomStatus check_ranges(const RomModel *m, uint32_t inputs, char *message, size_t message_size) {
    for (size_t r = 0; r < N_RULES(RANGE_RULES); r++) {
        const RangeRule *rule = &RANGE_RULES[r];
        const RomSection *s = rom_section(m, rule->tag);
        if (!s) continue;
        uint32_t first, end;
        rule_columns(rule->first_c, rule->first_i, rule->end_c, rule->end_i, inputs, s->cols, &first, &end);
        for (uint32_t i = 0; i < s->rows; i++) {
            for (uint32_t j = first; j < end; j++) {
                const double x = s->data[(size_t)i * s->cols + j];
                const int ok = (rule->low_open ? x > rule->low : x >= rule->low) &&
                               (rule->high_open ? x < rule->high : x <= rule->high);
                if (!ok && !(rule->has_also && x == rule->also)) {
                    return rom_fail(message, message_size, "resources: section '%s' row %u, column %u holds %g: %s "
                                    "is %s", s->tag, i + 1, j + 1, x, rule->what, rule->allowed);
                }
            }
        }
    }
    return ROM_OK;
}

static RomStatus check_row_sums(const RomModel *m, uint32_t inputs, char *message, size_t message_size) {
    for (size_t r = 0; r < N_RULES(ROW_SUM_RULES); r++) {
        const RowSumRule *rule = &ROW_SUM_RULES[r];
        const RomSection *s = rom_section(m, rule->tag);
        if (!s) continue;
        uint32_t first, end;
        rule_columns(rule->first_c, rule->first_i, rule->end_c, rule->end_i, inputs, s->cols, &first, &end);
        for (uint32_t i = 0; i < s->rows; i++) {
            double total = 0.0;
            for (uint32_t j = first; j < end; j++) total += s->data[(size_t)i * s->cols + j];
            if (!(fabs(total - rule->total) <= rule->tolerance)) {
                return rom_fail(message, message_size, "resources: section '%s' row %u: %s sum to %.17g (allowed: "
                                "%g to %g)", s->tag, i + 1, rule->what, total, rule->total, rule->tolerance);
            }
        }
    }
    return ROM_OK;
}

/* every value rule of the model's sections (once their shapes are checked) */
static RomStatus check_values(const RomModel *m, char *message, size_t message_size) {
    uint32_t inputs = 1u + m->n_ports;        /* the shadow's inputs: f and each port force, or f alone (SHSCAL) */
    const RomSection *scal = rom_section(m, "SHSCAL");
    if (scal && scal->rows == 1 && scal->cols == ROM_SHSCAL_COLUMNS && scal->data[ROM_SHSCAL_INPUTS] == 1.0) inputs = 1u;
    if (check_ranges(m, inputs, message, message_size) != ROM_OK) return ROM_FAIL;
    return check_row_sums(m, inputs, message, message_size);
}

/* the model's ports from its sections: all three sections or none, PORTB none with the port channel (section
 * PCSCAL: the channel takes every port force, the kind none) */
static RomStatus ports_prepare(RomModel *m, char *message, size_t message_size) {
    const RomSection *x = rom_section(m, "PORTX"), *b = rom_section(m, "PORTB"), *c = rom_section(m, "PORTC");
    if (!x && !b && !c) return ROM_OK;
    if (!b && x && c && rom_section(m, "PCSCAL")) b = NULL;
    else if (!x || !b || !c) {
        return rom_fail(message, message_size, "resources: the port sections PORTX, PORTB, PORTC come together "
                        "(%s missing)", !x ? "PORTX" : (!b ? "PORTB" : "PORTC"));
    }
    m->n_ports = x->cols;
    m->port_x = x->data;
    m->port_B = b ? b->data : NULL;
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
    const uint32_t n = rom_get_u32(bytes + start);
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
        const uint64_t rows = rom_get_u32(bytes + cursor + ROM_SECTION_TAG_SIZE);
        const uint64_t cols = rom_get_u32(bytes + cursor + ROM_SECTION_TAG_SIZE + 4);
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
        s->rows = rom_get_u32(bytes + cursor + ROM_SECTION_TAG_SIZE);
        s->cols = rom_get_u32(bytes + cursor + ROM_SECTION_TAG_SIZE + 4);
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
        for (uint64_t v = 0; v < count; v++, cursor += 8) next[v] = rom_get_f64(bytes + cursor);
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
    return rom_section(model, tag);
}

RomStatus rom_model_load_memory(const void *data, size_t size, RomModel **out, char *message, size_t message_size) {
    if (!out) return rom_fail(message, message_size, "resources: no output pointer");
    *out = NULL;
    const unsigned char *bytes = (const unsigned char *)data;
    if (rom_blob_open(&RESOURCES, bytes, size, message, message_size) != ROM_OK) return ROM_FAIL;
    const RomHeader h = read_header(bytes);
    const RomKindOps *kind = kind_ops(h.kind);
    if (!kind) return unsupported_kind(h.kind, message, message_size);
    if (check_header(kind, &h, message, message_size) != ROM_OK) return ROM_FAIL;
    /* the kind's own header, when the bytes before token and checksum hold it (else the length check names the
     * file as truncated) */
    const uint64_t head_end = (uint64_t)ROM_HEADER_SIZE + kind->head_size;
    uint64_t doubles = 0;
    if (head_end + ROM_TOKEN_SIZE + 4u > (uint64_t)size) {
        (void)rom_blob_close(&RESOURCES, bytes, size, head_end + 4u + ROM_TOKEN_SIZE + 4u, " for the model kind's "
                             "header", 0, NULL, message, message_size);       /* fails: the length */
        return ROM_FAIL;
    }
    if (kind->read_head && kind->read_head(&h, bytes + ROM_HEADER_SIZE, &doubles, message, message_size) != ROM_OK) {
        return ROM_FAIL;
    }
    const uint64_t sections_start = head_end + 8u * doubles;
    uint32_t n_sections = 0;
    uint64_t sections_end = 0;
    if (scan_sections(bytes, size, sections_start, &n_sections, &sections_end, message, message_size) != ROM_OK) {
        return ROM_FAIL;
    }
    const uint64_t expected = sections_end + ROM_TOKEN_SIZE + 4u;
    char detail[160];
    snprintf(detail, sizeof detail, " for %sk_v = %u, %s = %u, %u probes, flags 0x%x, %u sections",
             kind->length_subject, h.k_v, kind->k_rho_name, h.k_rho, h.n_probes, h.flags, n_sections);
    const size_t token_offset = (size_t)(expected - 4 - ROM_TOKEN_SIZE);
    if (rom_blob_close(&RESOURCES, bytes, size, expected, detail, token_offset, NULL, message, message_size) !=
        ROM_OK) {
        return ROM_FAIL;
    }
    if (!(isfinite(h.bound) && h.bound > 0) || !(isfinite(h.L) && h.L > 0)) {
        return rom_fail(message, message_size, "resources: runaway bound %g and L %g must be finite and > 0", h.bound,
                        h.L);
    }
    RomModel *m = (RomModel *)calloc(1, sizeof(RomModel));
    if (!m) return rom_fail(message, message_size, "resources: out of memory");
    m->kind = h.kind;
    m->ops = kind;
    m->k_v = h.k_v;
    m->k_rho = h.k_rho;
    m->n_probes = h.n_probes;
    m->flags = h.flags;
    m->runaway_bound = h.bound;
    m->L = h.L;
    m->kv_pad = (uint32_t)rom_round_up(h.k_v, 4);
    m->kr_pad = (uint32_t)rom_round_up(h.k_rho, 4);
    memcpy(m->token, bytes + token_offset, ROM_TOKEN_SIZE);
    m->token[ROM_TOKEN_SIZE] = '\0';
    const unsigned char *payload = bytes + ROM_HEADER_SIZE;
    RomStatus status = kind->load(m, payload, doubles, message, message_size);
    if (status == ROM_OK) status = read_sections(m, bytes, sections_start, n_sections, message, message_size);
    if (status == ROM_OK) status = check_values(m, message, message_size);     /* before any use of the values */
    if (status == ROM_OK) status = ports_prepare(m, message, message_size);
    if (status == ROM_OK) status = rom_channel_prepare(m, message, message_size);
    if (status == ROM_OK && kind->sections_ready) status = kind->sections_ready(m, message, message_size);
    if (status == ROM_OK) status = rom_bound_prepare(m, message, message_size);
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
    if (model->ops && model->ops->model_free) model->ops->model_free(model);
    free(model->bound.storage_);
    free(model->channel.storage_);
    free(model->sections_storage_);
    free(model);
}
