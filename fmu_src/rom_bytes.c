/*
 * Bytes and memory for the rest of the core: little-endian numbers, zlib's
 * CRC-32, the check both blob formats (rom.h: resources, serialized state)
 * share (size, magic, version, then after the caller's check of the header's
 * sizes: token, length, checksum), and the aligned zeroed arrays behind the
 * models and states.  It calls nothing of the core but rom_fail.
 */
#include "rom_internal.h"

#include <stdlib.h>

/* ------------------------------------------------------------------------ */
/* little-endian numbers                                                     */
/* ------------------------------------------------------------------------ */

uint32_t rom_get_u32(const unsigned char *p) {
    if (!p) return 0u;
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

uint64_t rom_get_u64(const unsigned char *p) {
    if (!p) return 0u;
    return (uint64_t)rom_get_u32(p) | ((uint64_t)rom_get_u32(p + 4) << 32);
}

double rom_get_f64(const unsigned char *p) {
    const uint64_t bits = rom_get_u64(p);
    double value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

void rom_put_u32(unsigned char *p, uint32_t v) {
    if (!p) return;
    p[0] = (unsigned char)(v & 0xffu);
    p[1] = (unsigned char)((v >> 8) & 0xffu);
    p[2] = (unsigned char)((v >> 16) & 0xffu);
    p[3] = (unsigned char)((v >> 24) & 0xffu);
}

void rom_put_u64(unsigned char *p, uint64_t v) {
    if (!p) return;
    rom_put_u32(p, (uint32_t)(v & 0xffffffffu));
    rom_put_u32(p + 4, (uint32_t)(v >> 32));
}

void rom_put_f64(unsigned char *p, double value) {
    uint64_t bits;
    memcpy(&bits, &value, sizeof bits);
    rom_put_u64(p, bits);
}

const unsigned char *rom_get_f64s(const unsigned char *cursor, double *out, size_t n) {
    if (!cursor || !out) return cursor;
    for (size_t i = 0; i < n; i++, cursor += 8) out[i] = rom_get_f64(cursor);
    return cursor;
}

unsigned char *rom_put_f64s(unsigned char *cursor, const double *values, size_t n) {
    if (!cursor || !values) return cursor;
    for (size_t i = 0; i < n; i++, cursor += 8) rom_put_f64(cursor, values[i]);
    return cursor;
}

/* ------------------------------------------------------------------------ */
/* CRC-32, token                                                             */
/* ------------------------------------------------------------------------ */

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
    for (size_t i = 0; bytes && i < size; i++) {
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
/* the checks shared by resources and serialized states                      */
/* ------------------------------------------------------------------------ */

RomStatus rom_blob_open(const RomBlob *e, const unsigned char *bytes, size_t size, char *message,
                        size_t message_size) {
    if (!e) return rom_fail(message, message_size, "no blob format");
    if (!bytes) return rom_fail(message, message_size, "%s: no data", e->what);
    if (size < e->min_size) {
        return rom_fail(message, message_size, "%s truncated: %zu bytes, fewer than the %zu of %s", e->what, size,
                        e->min_size, e->empty);
    }
    if (memcmp(bytes, e->magic, 8) != 0) {
        return rom_fail(message, message_size, "%s: bad magic (not %s)", e->what, e->contents);
    }
    const uint32_t version = rom_get_u32(bytes + 8);
    if (version < e->oldest || version > e->version) {
        if (e->oldest == e->version) {
            return rom_fail(message, message_size, "%s: format version %u is not supported (this binary reads %u%s)",
                            e->what, version, e->version, version < e->version ? e->older : "");
        }
        return rom_fail(message, message_size, "%s: format version %u is not supported (this binary reads %u and "
                        "%u%s)", e->what, version, e->version, e->oldest, version < e->oldest ? e->older : "");
    }
    return ROM_OK;
}

/* The token is compared before the checksum, so that a blob from another FMU is named as such. */
RomStatus rom_blob_close(const RomBlob *e, const unsigned char *bytes, size_t size, uint64_t expected,
                         const char *detail, size_t token_offset, const char *token, char *message,
                         size_t message_size) {
    if (!e || !bytes || !detail) return rom_fail(message, message_size, "blob check: bad arguments");
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
    const uint32_t stored = rom_get_u32(bytes + size - 4), crc = rom_crc32(bytes, size - 4);
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
/* arrays                                                                    */
/* ------------------------------------------------------------------------ */

void *rom_alloc_arrays(const size_t *counts, double **ptrs[], int n) {
    if (!counts || !ptrs || n < 0) return NULL;
    size_t total = 8;   /* slack for aligning the start */
    for (int i = 0; i < n; i++) total += rom_round_up(counts[i], 8);
    unsigned char *raw = (unsigned char *)calloc(total, sizeof(double));
    if (!raw) return NULL;
    double *cursor = (double *)(void *)(raw + ((64 - ((uintptr_t)raw & 63u)) & 63u));
    for (int i = 0; i < n; i++) {
        *ptrs[i] = counts[i] ? cursor : NULL;
        cursor += rom_round_up(counts[i], 8);
    }
    return raw;
}

int rom_arrays_finite(double **ptrs[], const size_t *counts, int n) {
    if (!ptrs || !counts) return 0;
    int finite = 1;
    for (int i = 0; i < n; i++) finite &= !*ptrs[i] || rom_all_finite(*ptrs[i], counts[i]);
    return finite;
}
