/*
 * The one message formatter of the C sources: the model core, the instance
 * layer and the C full SPH report a failure by writing a message into the
 * caller's buffer and returning ROM_FAIL.
 */
#include "rom.h"

#include <stdarg.h>
#include <stdio.h>

RomStatus rom_fail(char *message, size_t message_size, const char *format, ...) {
    if (message && message_size > 0) {
        va_list args;
        va_start(args, format);
        vsnprintf(message, message_size, format, args);
        va_end(args);
    }
    return ROM_FAIL;
}
