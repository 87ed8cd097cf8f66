/*
 * sphrom_load: a minimal FMI 2.0 / 3.0 co-simulation importer, the one C source compiled for every platform an
 * FMU carries a binary for (natively for linux64; with mingw-w64 for win64, run under wine).  Like a system
 * simulator it loads the FMU's shared library at run time (dlopen / LoadLibrary) and calls it through the FMI
 * functions only; it prints every output as the bits of its IEEE 754 double, so that the outputs of two
 * platforms' binaries compare bit for bit (tests/test_fmu_platforms.py).
 *
 *   sphrom_load SCRIPT
 *
 * SCRIPT is a text file, one command a line (a number is the 16 hex digits of a double's bits):
 *   fmi 2|3                  the FMI version
 *   library PATH             the FMU's shared library (binaries/<platform>/sphrom.<so|dll>)
 *   resources LOCATION       FMI 2: the resources folder's file URI; FMI 3: its path, ending in a separator
 *   token TEXT               the modelDescription's guid (FMI 2) / instantiationToken (FMI 3)
 *   instantiate              load the library and instantiate a co-simulation instance
 *   inputs N VR...           the Float64 inputs that each step sets
 *   outputs N VR...          the Float64 outputs that each step prints
 *   set VR BITS              set one Float64 variable (a parameter before initialize)
 *   initialize               enter and exit initialization mode at t = 0
 *   step H U1 ... UN         set the inputs, do one communication step of H seconds, print "t y1 ... yM"
 *   state                    print "state SIZE HEX...": the serialized FMU state
 *   end                      terminate, free the instance, unload the library
 * Every FMU message goes to stderr.  Exit status 0 when every call returned OK or Warning, else 1 with a line
 * naming the call.
 */
#if !defined(_WIN32)
#define _POSIX_C_SOURCE 200809L
#endif
#include <inttypes.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined(_WIN32)
#include <windows.h>
typedef HMODULE Library;
#else
#include <dlfcn.h>
typedef void *Library;
#endif

#include "fmi2FunctionTypes.h"
#include "fmi3FunctionTypes.h"

#define MAX_LINE 8192
#define MAX_VARIABLES 4096

typedef void (*Function)(void);

static Library open_library(const char *path) {
#if defined(_WIN32)
    return LoadLibraryA(path);
#else
    return dlopen(path, RTLD_NOW | RTLD_LOCAL);
#endif
}

static void close_library(Library library) {
#if defined(_WIN32)
    FreeLibrary(library);
#else
    dlclose(library);
#endif
}

/* the function ``name`` of the library, or exit naming it */
static Function symbol(Library library, const char *name) {
    Function f = NULL;
#if defined(_WIN32)
    FARPROC p = GetProcAddress(library, name);
#else
    void *p = dlsym(library, name);
#endif
    if (!p) {
        fprintf(stderr, "sphrom_load: the library exports no %s\n", name);
        exit(1);
    }
    memcpy(&f, &p, sizeof f);     /* object pointer to function pointer: defined on both platforms */
    return f;
}

#define FN(version, name) ((version##name##TYPE *)symbol(library, #version #name))

static void fail(const char *call, int line) {
    fprintf(stderr, "sphrom_load: %s failed (script line %d)\n", call, line);
    exit(1);
}

static void logger2(fmi2ComponentEnvironment environment, fmi2String name, fmi2Status status, fmi2String category,
                    fmi2String message, ...) {
    (void)environment;
    va_list args;
    va_start(args, message);
    fprintf(stderr, "[%s] %d %s: ", name ? name : "", (int)status, category ? category : "");
    vfprintf(stderr, message ? message : "", args);
    fputc('\n', stderr);
    va_end(args);
}

static void logger3(fmi3InstanceEnvironment environment, fmi3Status status, fmi3String category,
                    fmi3String message) {
    (void)environment;
    fprintf(stderr, "%d %s: %s\n", (int)status, category ? category : "", message ? message : "");
}

static double from_bits(const char *text, int line) {
    char *end = NULL;
    const unsigned long long bits = strtoull(text, &end, 16);
    if (!text[0] || *end) fail("reading a number's bits", line);
    const uint64_t word = (uint64_t)bits;
    double x;
    memcpy(&x, &word, sizeof x);
    return x;
}

static void print_bits(double x) {
    uint64_t word;
    memcpy(&word, &x, sizeof word);
    printf("%016" PRIx64, word);
}

/* the whitespace-separated words of ``line`` (modified in place); returns their count */
static int split(char *line, char **words, int max_words) {
    int n = 0;
    for (char *w = strtok(line, " \t\r\n"); w && n < max_words; w = strtok(NULL, " \t\r\n")) words[n++] = w;
    return n;
}

/* the rest of the line after its first word (a path may hold spaces) */
static const char *rest(char *line) {
    char *p = line + strcspn(line, " \t");
    p += strspn(p, " \t");
    p[strcspn(p, "\r\n")] = '\0';
    return p;
}

static int ok2(fmi2Status s) { return s == fmi2OK || s == fmi2Warning; }
static int ok3(fmi3Status s) { return s == fmi3OK || s == fmi3Warning; }

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: sphrom_load SCRIPT\n");
        return 2;
    }
    FILE *script = fopen(argv[1], "r");
    if (!script) {
        fprintf(stderr, "sphrom_load: cannot open %s\n", argv[1]);
        return 2;
    }
    static char line[MAX_LINE], copy[MAX_LINE], library_path[MAX_LINE], resources[MAX_LINE], token[MAX_LINE];
    static char *words[MAX_VARIABLES + 2];
    static unsigned int in_vr[MAX_VARIABLES], out_vr[MAX_VARIABLES];
    static double in_value[MAX_VARIABLES], out_value[MAX_VARIABLES];
    size_t n_in = 0, n_out = 0;
    int fmi = 0, number = 0;
    double t = 0.0;
    Library library = NULL;
    fmi2Component c2 = NULL;
    fmi3Instance c3 = NULL;
    fmi2CallbackFunctions callbacks = {logger2, calloc, free, NULL, NULL};
    while (fgets(line, sizeof line, script)) {
        number++;
        memcpy(copy, line, sizeof line);
        const int n = split(line, words, MAX_VARIABLES + 2);
        if (n == 0) continue;
        const char *command = words[0];
        if (strcmp(command, "fmi") == 0 && n == 2) {
            fmi = atoi(words[1]);
            if (fmi != 2 && fmi != 3) fail("fmi (2 or 3)", number);
        } else if (strcmp(command, "library") == 0) {
            snprintf(library_path, sizeof library_path, "%s", rest(copy));
        } else if (strcmp(command, "resources") == 0) {
            snprintf(resources, sizeof resources, "%s", rest(copy));
        } else if (strcmp(command, "token") == 0) {
            snprintf(token, sizeof token, "%s", rest(copy));
        } else if (strcmp(command, "instantiate") == 0) {
            library = open_library(library_path);
            if (!library) fail("loading the library", number);
            if (fmi == 2) {
                c2 = FN(fmi2, Instantiate)("load", fmi2CoSimulation, token, resources, &callbacks, fmi2False,
                                           fmi2False);
                if (!c2) fail("fmi2Instantiate", number);
            } else {
                c3 = FN(fmi3, InstantiateCoSimulation)("load", token, resources, fmi3False, fmi3False, fmi3False,
                                                       fmi3False, NULL, 0, NULL, logger3, NULL);
                if (!c3) fail("fmi3InstantiateCoSimulation", number);
            }
        } else if ((strcmp(command, "inputs") == 0 || strcmp(command, "outputs") == 0) && n >= 2) {
            const int inputs = command[0] == 'i';
            const size_t count = (size_t)strtoul(words[1], NULL, 10);
            if (count > MAX_VARIABLES || (size_t)n != count + 2) fail(command, number);
            for (size_t i = 0; i < count; i++) (inputs ? in_vr : out_vr)[i] = (unsigned)strtoul(words[i + 2], NULL, 10);
            *(inputs ? &n_in : &n_out) = count;
        } else if (strcmp(command, "set") == 0 && n == 3) {
            const unsigned int vr = (unsigned)strtoul(words[1], NULL, 10);
            const double x = from_bits(words[2], number);
            if (fmi == 2 ? !ok2(FN(fmi2, SetReal)(c2, &vr, 1, &x)) : !ok3(FN(fmi3, SetFloat64)(c3, &vr, 1, &x, 1))) {
                fail("setting a Float64", number);
            }
        } else if (strcmp(command, "initialize") == 0) {
            if (fmi == 2) {
                if (!ok2(FN(fmi2, SetupExperiment)(c2, fmi2False, 0.0, 0.0, fmi2False, 0.0))) fail("setup", number);
                if (!ok2(FN(fmi2, EnterInitializationMode)(c2))) fail("fmi2EnterInitializationMode", number);
                if (!ok2(FN(fmi2, ExitInitializationMode)(c2))) fail("fmi2ExitInitializationMode", number);
            } else {
                if (!ok3(FN(fmi3, EnterInitializationMode)(c3, fmi3False, 0.0, 0.0, fmi3False, 0.0))) {
                    fail("fmi3EnterInitializationMode", number);
                }
                if (!ok3(FN(fmi3, ExitInitializationMode)(c3))) fail("fmi3ExitInitializationMode", number);
            }
        } else if (strcmp(command, "step") == 0 && (size_t)n == n_in + 2) {
            const double h = from_bits(words[1], number);
            for (size_t i = 0; i < n_in; i++) in_value[i] = from_bits(words[i + 2], number);
            if (fmi == 2) {
                if (n_in && !ok2(FN(fmi2, SetReal)(c2, in_vr, n_in, in_value))) fail("fmi2SetReal", number);
                if (!ok2(FN(fmi2, DoStep)(c2, t, h, fmi2True))) fail("fmi2DoStep", number);
                if (n_out && !ok2(FN(fmi2, GetReal)(c2, out_vr, n_out, out_value))) fail("fmi2GetReal", number);
            } else {
                fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
                fmi3Float64 last = 0.0;
                if (n_in && !ok3(FN(fmi3, SetFloat64)(c3, in_vr, n_in, in_value, n_in))) fail("fmi3SetFloat64", number);
                if (!ok3(FN(fmi3, DoStep)(c3, t, h, fmi3True, &event, &terminate, &early, &last))) {
                    fail("fmi3DoStep", number);
                }
                if (n_out && !ok3(FN(fmi3, GetFloat64)(c3, out_vr, n_out, out_value, n_out))) {
                    fail("fmi3GetFloat64", number);
                }
            }
            t += h;
            print_bits(t);
            for (size_t i = 0; i < n_out; i++) {
                putchar(' ');
                print_bits(out_value[i]);
            }
            putchar('\n');
        } else if (strcmp(command, "state") == 0) {
            size_t size = 0;
            unsigned char *bytes = NULL;
            int good;
            if (fmi == 2) {
                fmi2FMUstate state = NULL;
                good = ok2(FN(fmi2, GetFMUstate)(c2, &state)) && ok2(FN(fmi2, SerializedFMUstateSize)(c2, state, &size))
                       && (bytes = malloc(size ? size : 1)) != NULL
                       && ok2(FN(fmi2, SerializeFMUstate)(c2, state, (fmi2Byte *)bytes, size))
                       && ok2(FN(fmi2, FreeFMUstate)(c2, &state));
            } else {
                fmi3FMUState state = NULL;
                good = ok3(FN(fmi3, GetFMUState)(c3, &state)) && ok3(FN(fmi3, SerializedFMUStateSize)(c3, state, &size))
                       && (bytes = malloc(size ? size : 1)) != NULL
                       && ok3(FN(fmi3, SerializeFMUState)(c3, state, bytes, size))
                       && ok3(FN(fmi3, FreeFMUState)(c3, &state));
            }
            if (!good) fail("serializing the FMU state", number);
            printf("state %zu ", size);
            for (size_t i = 0; i < size; i++) printf("%02x", bytes[i]);
            putchar('\n');
            free(bytes);
        } else if (strcmp(command, "end") == 0) {
            if (fmi == 2) {
                if (!ok2(FN(fmi2, Terminate)(c2))) fail("fmi2Terminate", number);
                FN(fmi2, FreeInstance)(c2);
                c2 = NULL;
            } else {
                if (!ok3(FN(fmi3, Terminate)(c3))) fail("fmi3Terminate", number);
                FN(fmi3, FreeInstance)(c3);
                c3 = NULL;
            }
            close_library(library);
            library = NULL;
        } else {
            fail("an unknown or malformed command", number);
        }
    }
    fclose(script);
    fflush(stdout);
    return 0;
}
