/*
 * The serialized FMU state (rom_layout.h's format, generated from harness/fmu/layout.py): the header, a^v and
 * a^rho, the kind's block (asked of the model's table: state_doubles, state_check, state_put, state_get; the
 * frozen kind's holds its parameters n_freeze and dt), the time since the start and df/dt, the parameters a state carries, the ports;
 * read through the envelope check rom_bytes.c shares with the resources.
 */
#include "rom_internal.h"

#include <stdio.h>

static const RomBlob STATE = {"serialized state", ROM_STATE_MAGIC, "an sphrom FMU state", "an empty state",
                              "a state", "", ROM_STATE_VERSION, ROM_STATE_OLDEST_VERSION, ROM_STATE_HEADER_SIZE + 4,
                              "; a state restores only into the FMU that wrote it, whose token hashes its model.bin, "
                              "and a state of an older format comes from an FMU of an older model.bin format, which "
                              "no FMU of this binary has"};

/* The state's values in the order they are serialized: a^v [k_v], a^rho [k_rho] (linear: a, b), the kind's
 * block (state_put: frozen n_freeze, dt, M^T (k_v rows of k_rho) and F [k_v]; linear the forced part X [k]), then
 * the time since the start (format 4: the start time t0) and the input rate, the error bounds' shadow and the port
 * channel.  The parameters a state carries follow them (params_put, params_get). */
static unsigned char *blocks_put(const RomState *s, unsigned char *cursor) {
    const RomModel *m = s->model;
    cursor = rom_put_f64s(cursor, s->av, m->k_v);
    cursor = rom_put_f64s(cursor, s->ar, m->k_rho);
    cursor = m->ops->state_put(s, cursor);
    const double times[2] = {s->elapsed, s->f_rate};
    cursor = rom_put_f64s(cursor, times, 2);
    cursor = rom_bound_state_put(s, cursor);           /* the error bounds' shadow (rom_bound.c) */
    return rom_channel_state_put(s, cursor);           /* the port channel (rom_port.c) */
}

static const unsigned char *blocks_get(RomState *s, const unsigned char *cursor, uint32_t version) {
    const RomModel *m = s->model;
    cursor = rom_get_f64s(cursor, s->av, m->k_v);
    cursor = rom_get_f64s(cursor, s->ar, m->k_rho);
    cursor = m->ops->state_get(s, cursor);
    double times[2];
    cursor = rom_get_f64s(cursor, times, 2);
    s->elapsed = version == ROM_STATE_VERSION ? times[0] : s->time - times[0];     /* format 4: t0 */
    s->f_rate = times[1];
    cursor = rom_bound_state_get(s, cursor);
    return rom_channel_state_get(s, cursor);
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

/* The parameters a state carries, after the kind's blocks: initial_state_scale, c, d */
#define PARAM_VALUES 3

static unsigned char *params_put(const RomState *s, unsigned char *cursor) {
    const double values[PARAM_VALUES] = {s->initial_state_scale, s->c, s->d};
    return rom_put_f64s(cursor, values, PARAM_VALUES);
}

static const unsigned char *params_get(RomState *s, const unsigned char *cursor) {
    double values[PARAM_VALUES];
    cursor = rom_get_f64s(cursor, values, PARAM_VALUES);
    s->initial_state_scale = values[0];
    s->c = values[1];
    s->d = values[2];
    return cursor;
}

/* the blocks (blocks_put), in doubles: the last is the port channel's (rom_port.c; none without it) */
static size_t kind_doubles(const RomModel *m) {
    return (size_t)m->k_v + m->k_rho + m->ops->state_doubles(m) + 2 + rom_bound_state_doubles(m) +
           rom_channel_state_doubles(m);
}

static size_t state_doubles(const RomModel *m) {
    return kind_doubles(m) + PARAM_VALUES + port_values(m);
}

size_t rom_state_serialized_size(const RomModel *m) {
    if (!m || !m->ops) return 0;
    return ROM_STATE_HEADER_SIZE + 8 * state_doubles(m) + 4;
}

void rom_state_serialize(const RomState *s, uint32_t tag, unsigned char *buffer) {
    if (!s || !buffer) return;
    const RomModel *m = s->model;
    const size_t size = rom_state_serialized_size(m);
    memset(buffer, 0, size);
    memcpy(buffer, ROM_STATE_MAGIC, 8);
    rom_put_u32(buffer + ROM_STATE_STATE_VERSION, ROM_STATE_VERSION);
    rom_put_u32(buffer + ROM_STATE_TAG, tag);
    rom_put_u32(buffer + ROM_STATE_K_V, m->k_v);
    rom_put_u32(buffer + ROM_STATE_K_RHO, m->k_rho);
    rom_put_u32(buffer + ROM_STATE_N_PROBES, m->n_probes);
    rom_put_u32(buffer + ROM_STATE_RESERVED, 0);
    memcpy(buffer + ROM_STATE_TOKEN, m->token, ROM_TOKEN_SIZE);
    rom_put_u64(buffer + ROM_STATE_N, (uint64_t)s->n);
    rom_put_f64(buffer + ROM_STATE_TIME, s->time);
    rom_put_f64(buffer + ROM_STATE_F, s->f);
    unsigned char *cursor = blocks_put(s, buffer + ROM_STATE_HEADER_SIZE);
    cursor = params_put(s, cursor);
    cursor = ports_put(s, cursor);
    rom_put_u32(cursor, rom_crc32(buffer, size - 4));
}

/* The parameters a state carries (params: the first after the kind's blocks), each named when refused:
 * initial_state_scale finite; c, d inside a varied parameter's trained range, equal to the model's value of a
 * fixed one, 0 in a model without them; with ports the area finite and > 0. */
static RomStatus check_params_in_state(const RomModel *m, const unsigned char *params, char *message,
                                       size_t message_size) {
    const double scale = rom_get_f64(params);
    if (!(fabs(scale) <= ROM_MAX_INITIAL_STATE_SCALE)) {
        return rom_fail(message, message_size, "serialized state: parameter initial_state_scale = %g is out of range "
                        "(allowed: [-%g, %g])", scale, ROM_MAX_INITIAL_STATE_SCALE, ROM_MAX_INITIAL_STATE_SCALE);
    }
    const RomSection *section = rom_section(m, "PARAMS");
    for (int which = ROM_PARAM_C; which <= ROM_PARAM_D; which++) {
        const char *name = which == ROM_PARAM_C ? "c" : "d";
        const double value = rom_get_f64(params + 8 * (1 + which));
        if (!section) {
            if (value != 0.0) {
                return rom_fail(message, message_size, "serialized state: parameter %s = %g, but this FMU has no "
                                "parameter %s (expected 0)", name, value, name);
            }
            continue;
        }
        const double *row = section->data + ROM_PARAMS_COLUMNS * which;
        const double start = row[ROM_PARAMS_START], lo = row[ROM_PARAMS_MIN], hi = row[ROM_PARAMS_MAX];
        if (row[ROM_PARAMS_VARIED] == 0.0 && !(value == start)) {
            return rom_fail(message, message_size, "serialized state: parameter %s = %g, but this FMU's %s is fixed "
                            "at %g", name, value, name, start);
        }
        if (!(isfinite(value) && value >= lo && value <= hi)) {
            return rom_fail(message, message_size, "serialized state: parameter %s = %g is outside the trained range "
                            "[%g, %g]", name, value, lo, hi);
        }
    }
    if (m->n_ports) {                  /* the area: the first value after the parameters */
        const double area = rom_get_f64(params + 8 * PARAM_VALUES);
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
    static const struct { const char *field; size_t offset; } SIZES[3] = {
        {"k_v", ROM_STATE_K_V}, {"k_rho", ROM_STATE_K_RHO}, {"n_probes", ROM_STATE_N_PROBES}};
    const uint32_t mine[3] = {m->k_v, m->k_rho, m->n_probes};
    for (int i = 0; i < 3; i++) {
        const uint32_t theirs = rom_get_u32(buffer + SIZES[i].offset);
        if (theirs != mine[i]) {
            return rom_fail(message, message_size, "serialized state: %s is %u in the state, %u in this FMU (a state "
                            "from another FMU)", SIZES[i].field, theirs, mine[i]);
        }
    }
    if (rom_blob_close(&STATE, buffer, size, rom_state_serialized_size(m), "", ROM_STATE_TOKEN, m->token, message,
                       message_size) != ROM_OK) {
        return ROM_FAIL;
    }
    const int64_t n = (int64_t)rom_get_u64(buffer + ROM_STATE_N);
    const uint32_t reserved = rom_get_u32(buffer + ROM_STATE_RESERVED);
    const double time = rom_get_f64(buffer + ROM_STATE_TIME), f = rom_get_f64(buffer + ROM_STATE_F);
    if (n < 0 || reserved != 0 || !isfinite(time) || !isfinite(f)) {
        return rom_fail(message, message_size, "serialized state: invalid values (step %lld, reserved %u, t %g, f %g)",
                        (long long)n, reserved, time, f);
    }
    /* the kind's rules on its block (the frozen kind's n_freeze and dt), the parameters, then every value finite */
    const unsigned char *block = buffer + ROM_STATE_HEADER_SIZE + 8 * ((size_t)m->k_v + m->k_rho);
    if (m->ops->state_check && m->ops->state_check(m, block, message, message_size) != ROM_OK) return ROM_FAIL;
    /* the time since the start (format 5; format 4's start time t0 is any finite time): the sum of the steps */
    const double since = rom_get_f64(block + 8 * m->ops->state_doubles(m));
    const double elapsed = rom_get_u32(buffer + 8) == ROM_STATE_VERSION ? since : time - since;
    if (!(isfinite(elapsed) && elapsed >= 0)) {
        return rom_fail(message, message_size, "serialized state: the time since the start %g s is out of range "
                        "(allowed: a finite number >= 0)", elapsed);
    }
    const unsigned char *params = buffer + ROM_STATE_HEADER_SIZE + 8 * kind_doubles(m);
    if (check_params_in_state(m, params, message, message_size) != ROM_OK) return ROM_FAIL;
    if (rom_channel_state_check(m, params - 8 * rom_channel_state_doubles(m), message, message_size) != ROM_OK) {
        return ROM_FAIL;
    }
    const unsigned char *cursor = buffer + ROM_STATE_HEADER_SIZE;
    for (size_t i = 0; i < state_doubles(m); i++, cursor += 8) {
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
    if (tag) *tag = rom_get_u32(buffer + ROM_STATE_TAG);
    s->n = (int64_t)rom_get_u64(buffer + ROM_STATE_N);
    s->time = rom_get_f64(buffer + ROM_STATE_TIME);
    s->f = rom_get_f64(buffer + ROM_STATE_F);
    const unsigned char *cursor = blocks_get(s, buffer + ROM_STATE_HEADER_SIZE, rom_get_u32(buffer + 8));
    cursor = params_get(s, cursor);
    (void)ports_get(s, cursor);
    rom_outputs_moved(s);                               /* the kept outputs were the old state's */
    return ROM_OK;
}
