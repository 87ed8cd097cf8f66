/*
 * The serialized FMU state (rom.h's format): the header, a^v and a^rho, the
 * kind's block (asked of the model's table: state_doubles, state_put,
 * state_get), t0 and df/dt, the parameters a state carries, the ports; read
 * through the envelope check rom_bytes.c shares with the resources.
 */
#include "rom_internal.h"

#include <stdio.h>

static const RomBlob STATE = {"serialized state", ROM_STATE_MAGIC, "an sphrom FMU state", "an empty state",
                              "a state", "", ROM_STATE_VERSION, ROM_STATE_HEADER_SIZE + 4, ROM_STATE_VERSION_OLDEST};

/* byte offsets of the state header's fields (rom.h) */
enum {
    ST_TAG = 12, ST_K_V = 16, ST_K_RHO = 20, ST_N_PROBES = 24, ST_N_PAIRS = 28, ST_TOKEN = 32,
    ST_N = 72, ST_N_FREEZE = 80, ST_RESERVED = 84, ST_TIME = 88, ST_F = 96, ST_DT = 104
};

/* The state's values in the order they are serialized: a^v [k_v], a^rho [k_rho] (linear: a, b), the kind's
 * block (state_put: frozen M^T (k_v rows of k_rho) and F [k_v]; linear the forced part X [k]), then t0 and the
 * input rate.  The parameters a state carries follow them (params_put, params_get). */
static unsigned char *blocks_put(const RomState *s, unsigned char *cursor) {
    const RomModel *m = s->model;
    cursor = rom_put_f64s(cursor, s->av, m->k_v);
    cursor = rom_put_f64s(cursor, s->ar, m->k_rho);
    cursor = m->ops->state_put(s, cursor);
    const double times[2] = {s->t0, s->f_rate};
    cursor = rom_put_f64s(cursor, times, 2);
    return rom_bound_state_put(s, cursor);             /* the error bounds' shadow (rom_bound.c) */
}

static const unsigned char *blocks_get(RomState *s, const unsigned char *cursor) {
    const RomModel *m = s->model;
    cursor = rom_get_f64s(cursor, s->av, m->k_v);
    cursor = rom_get_f64s(cursor, s->ar, m->k_rho);
    cursor = m->ops->state_get(s, cursor);
    double times[2];
    cursor = rom_get_f64s(cursor, times, 2);
    s->t0 = times[0];
    s->f_rate = times[1];
    return rom_bound_state_get(s, cursor);
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
    rom_put_f64(cursor, s->area);
    cursor += 8;
    for (size_t j = 0; j < n; j++, cursor += 8) rom_put_f64(cursor, s->port_force[j]);
    rom_put_f64(cursor, s->port_driven);
    cursor += 8;
    for (size_t j = 0; j < n; j++, cursor += 8) rom_put_f64(cursor, s->port_rate[j]);
    return cursor;
}

static const unsigned char *ports_get(RomState *s, const unsigned char *cursor) {
    const size_t n = s->model->n_ports;
    if (!n) return cursor;
    s->area = rom_get_f64(cursor);
    cursor += 8;
    for (size_t j = 0; j < n; j++, cursor += 8) s->port_force[j] = rom_get_f64(cursor);
    s->port_driven = rom_get_f64(cursor) != 0.0 ? 1.0 : 0.0;
    cursor += 8;
    for (size_t j = 0; j < n; j++, cursor += 8) s->port_rate[j] = rom_get_f64(cursor);
    return cursor;
}

/* The parameters a state carries, after the kind's blocks: initial_state_scale, then (version 3) c, d */
static size_t param_values(uint32_t version) {
    return version >= 3 ? 3 : 1;
}

static unsigned char *params_put(const RomState *s, unsigned char *cursor) {
    const double values[3] = {s->initial_state_scale, s->c, s->d};
    for (size_t i = 0; i < param_values(ROM_STATE_VERSION); i++, cursor += 8) rom_put_f64(cursor, values[i]);
    return cursor;
}

static const unsigned char *params_get(RomState *s, uint32_t version, const unsigned char *cursor) {
    double *const fields[3] = {&s->initial_state_scale, &s->c, &s->d};
    for (size_t i = 0; i < param_values(version); i++, cursor += 8) *fields[i] = rom_get_f64(cursor);
    return cursor;
}

/* the blocks (blocks_put), in doubles */
static size_t kind_doubles(const RomModel *m) {
    return (size_t)m->k_v + m->k_rho + m->ops->state_doubles(m) + 2 + rom_bound_state_doubles(m);
}

static size_t state_doubles(const RomModel *m, uint32_t version) {
    return kind_doubles(m) + param_values(version) + port_values(m);
}

size_t rom_state_serialized_size_version(const RomModel *m, uint32_t version) {
    if (!m || !m->ops || version < ROM_STATE_VERSION_OLDEST || version > ROM_STATE_VERSION) return 0;
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
    rom_put_u32(buffer + 8, ROM_STATE_VERSION);
    rom_put_u32(buffer + ST_TAG, tag);
    rom_put_u32(buffer + ST_K_V, m->k_v);
    rom_put_u32(buffer + ST_K_RHO, m->k_rho);
    rom_put_u32(buffer + ST_N_PROBES, m->n_probes);
    rom_put_u32(buffer + ST_N_PAIRS, m->n_pairs);
    memcpy(buffer + ST_TOKEN, m->token, ROM_TOKEN_SIZE);
    rom_put_u64(buffer + ST_N, (uint64_t)s->n);
    rom_put_u32(buffer + ST_N_FREEZE, (uint32_t)s->n_freeze);
    rom_put_u32(buffer + ST_RESERVED, 0);
    rom_put_f64(buffer + ST_TIME, s->time);
    rom_put_f64(buffer + ST_F, s->f);
    rom_put_f64(buffer + ST_DT, s->dt);
    unsigned char *cursor = blocks_put(s, buffer + ROM_STATE_HEADER_SIZE);
    cursor = params_put(s, cursor);
    cursor = ports_put(s, cursor);
    rom_put_u32(cursor, rom_crc32(buffer, size - 4));
}

/* The parameters a state of this version carries (offset: the first after the kind's blocks), each named when
 * refused: initial_state_scale finite; c, d (version 3) inside a varied parameter's trained range, equal to the
 * model's value of a fixed one, 0 in a model without them; with ports the area finite and > 0. */
static RomStatus check_params_in_state(const RomModel *m, uint32_t version, const unsigned char *params,
                                       char *message, size_t message_size) {
    const double scale = rom_get_f64(params);
    if (!isfinite(scale)) {
        return rom_fail(message, message_size, "serialized state: parameter initial_state_scale = %g is out of range "
                        "(allowed: a finite real number)", scale);
    }
    if (version >= 3) {
        const RomSection *section = rom_section(m, "PARAMS");
        for (int which = ROM_PARAM_C; which <= ROM_PARAM_D; which++) {
            const char *name = which == ROM_PARAM_C ? "c" : "d";
            const double value = rom_get_f64(params + 8 * (1 + which));
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
        const double area = rom_get_f64(params + 8 * param_values(version));
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
    if (rom_blob_open(&STATE, buffer, size, message, message_size) != ROM_OK) return ROM_FAIL;
    const uint32_t version = rom_get_u32(buffer + 8);
    static const struct { const char *field; size_t offset; } SIZES[4] = {
        {"k_v", ST_K_V}, {"k_rho", ST_K_RHO}, {"n_probes", ST_N_PROBES}, {"n_pairs", ST_N_PAIRS}};
    const uint32_t mine[4] = {m->k_v, m->k_rho, m->n_probes, m->n_pairs};
    for (int i = 0; i < 4; i++) {
        const uint32_t theirs = rom_get_u32(buffer + SIZES[i].offset);
        if (theirs != mine[i]) {
            return rom_fail(message, message_size, "serialized state: %s is %u in the state, %u in this FMU (a state "
                            "from another FMU)", SIZES[i].field, theirs, mine[i]);
        }
    }
    char detail[48];
    snprintf(detail, sizeof detail, " for state version %u", version);
    if (rom_blob_close(&STATE, buffer, size, rom_state_serialized_size_version(m, version),
                       version == ROM_STATE_VERSION ? "" : detail, ST_TOKEN, m->token, message,
                       message_size) != ROM_OK) {
        return ROM_FAIL;
    }
    const int64_t n = (int64_t)rom_get_u64(buffer + ST_N);
    const int64_t n_freeze = (int32_t)rom_get_u32(buffer + ST_N_FREEZE);
    const double time = rom_get_f64(buffer + ST_TIME), f = rom_get_f64(buffer + ST_F), dt = rom_get_f64(buffer + ST_DT);
    if (n < 0 || n_freeze < 1 || !isfinite(time) || !isfinite(f) || !(isfinite(dt) && dt > 0)) {
        return rom_fail(message, message_size, "serialized state: invalid values (step %lld, n_freeze %lld, t %g, "
                        "f %g, dt %g)", (long long)n, (long long)n_freeze, time, f, dt);
    }
    const double floor_dt = rom_dt_floor(m);
    if (dt < floor_dt) {                       /* the work of a doStep grows as 1/dt (rom.h) */
        return rom_fail(message, message_size, "serialized state: dt = %g s is below its floor %g s (allowed: dt >= "
                        "%g s, the model's dt %g s x %g)", dt, floor_dt, floor_dt, m->dt, ROM_DT_FLOOR_RATIO);
    }
    const unsigned char *params = buffer + ROM_STATE_HEADER_SIZE + 8 * kind_doubles(m);
    if (check_params_in_state(m, version, params, message, message_size) != ROM_OK) return ROM_FAIL;
    const unsigned char *cursor = buffer + ROM_STATE_HEADER_SIZE;
    for (size_t i = 0; i < state_doubles(m, version); i++, cursor += 8) {
        if (!isfinite(rom_get_f64(cursor))) {
            return rom_fail(message, message_size, "serialized state: non-finite reduced state");
        }
    }
    return ROM_OK;
}

RomStatus rom_state_deserialize(RomState *s, const unsigned char *buffer, size_t size, uint32_t *tag, char *message,
                                size_t message_size) {
    if (!s) return rom_fail(message, message_size, "no state");
    if (rom_state_check(s->model, buffer, size, message, message_size) != ROM_OK) return ROM_FAIL;
    if (tag) *tag = rom_get_u32(buffer + ST_TAG);
    s->n = (int64_t)rom_get_u64(buffer + ST_N);
    s->n_freeze = (int32_t)rom_get_u32(buffer + ST_N_FREEZE);
    s->time = rom_get_f64(buffer + ST_TIME);
    s->f = rom_get_f64(buffer + ST_F);
    s->dt = rom_get_f64(buffer + ST_DT);
    const unsigned char *cursor = blocks_get(s, buffer + ROM_STATE_HEADER_SIZE);
    cursor = params_get(s, rom_get_u32(buffer + 8), cursor);
    (void)ports_get(s, cursor);
    return ROM_OK;
}
