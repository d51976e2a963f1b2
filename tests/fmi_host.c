/* A minimal FMI co-simulation host for the tests: no Python in the process.
 * One source for both standards, chosen when it is compiled: -DHOST_FMI=2
 * (the default) builds fmi_host, -DHOST_FMI=3 builds fmi3_host.  Both read the
 * same script language and print the same output, so one script runs an
 * FMU's FMI 2.0 and FMI 3.0 builds alike.
 *
 *     fmi_host [--stack BYTES] LIBRARY GUID [RESOURCES_URI] < script
 *     fmi3_host [--stack BYTES] LIBRARY INSTANTIATION_TOKEN < script
 *
 * --stack runs the script on a thread of its own whose stack is BYTES long
 * (POSIX only), as an importer that steps FMUs from a secondary thread does
 * (macOS gives those 512 kB): below the stack lies a guard page, so an FMU
 * that needs more crashes the host rather than writing past it, and after
 * the script a last line "stack USED" says how many bytes of it the run
 * touched (the stack is painted before, the untouched paint counted after;
 * the host's own frames and the thread's TLS included).
 *
 * (RESOURCES_URI, e.g. file:///tmp/x/resources, for an FMU that reads its
 * resources: the container FMU of a system) loads the FMU's binary (dlopen, or LoadLibrary when built with MinGW) and runs
 * a script of one command per line, printing one line per command:
 * "<command> <status> [values]"; the FMU's log lines come as "log <status>
 * <category> <message>".  Commands:
 *
 *   new K NAME      instantiate into slot K (0..15) and use it    use K
 *   setup T0 | enter | exit | term | reset | free   (FMI 3.0: setup keeps T0 for enter:
 *                   fmi3EnterInitializationMode takes the start time)
 *   setr VR X | seti VR N | sets VR TEXT | getr VR... | geti VR... | gets VR...
 *   setl VR N | getl VR...            FMI 3.0 only: Int64 (an enumeration)
 *   step T H        DoStep(T, H); FMI 3.0's event, terminate and early-return flags must stay false
 *   run T H N VR... N steps of H from T, a "row t values" line after each
 *   save K | load K | drop K           GetFMUstate / SetFMUstate / FreeFMUstate in state slot K
 *   dropstate K     FMI 3.0 only: fmi3FreeFMUState given the state itself, not its address
 *                   (fmusim 0.0.39's mistake)
 *   ser K FILE | deser K FILE          serialise state slot K to a file / from a file into slot K
 *   bench N T H VRIN VROUT...          N x (setReal VRIN, doStep, getReal VROUT...): ns per step
 *   ddr VRIN VROUT...                  FMI 2.0 only: fmi2GetDirectionalDerivative of the outputs
 *                                      along input VRIN (seed 1)
 *   null            call DoStep on a NULL instance (must not crash)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdarg.h>
#include <time.h>

#ifndef HOST_FMI
#define HOST_FMI 2
#endif

/* The FMI functions the host calls, as X(field, symbol): the rest of the file
 * calls them through the fields, by one name for both standards. */
#if HOST_FMI == 3
#include "fmi3Functions.h"
#define HOST_NAME "fmi3_host"
#define HOST_USAGE "[--stack BYTES] LIBRARY INSTANTIATION_TOKEN"
#define HOST_FUNCTIONS(X) \
    X(instantiate, fmi3InstantiateCoSimulation) X(free_instance, fmi3FreeInstance) \
    X(enter, fmi3EnterInitializationMode) X(exit, fmi3ExitInitializationMode) X(terminate, fmi3Terminate) \
    X(reset, fmi3Reset) X(set_real, fmi3SetFloat64) X(set_integer, fmi3SetInt32) X(set_int64, fmi3SetInt64) \
    X(set_string, fmi3SetString) X(get_real, fmi3GetFloat64) X(get_integer, fmi3GetInt32) \
    X(get_int64, fmi3GetInt64) X(get_string, fmi3GetString) X(do_step, fmi3DoStep) \
    X(get_state, fmi3GetFMUState) X(set_state, fmi3SetFMUState) X(free_state, fmi3FreeFMUState) \
    X(state_size, fmi3SerializedFMUStateSize) X(serialize, fmi3SerializeFMUState) \
    X(deserialize, fmi3DeserializeFMUState)
typedef fmi3Instance Instance;
typedef fmi3FMUState State;
typedef fmi3ValueReference ValueReference;
typedef fmi3Int32 Int32;
typedef fmi3String String;
typedef fmi3Byte Byte;
/* FMI 3.0's getters and setters take the number of values once more, after the values */
#define NVALUES(n) , (size_t)(n)
#elif HOST_FMI == 2
#include "fmi2Functions.h"
#define HOST_NAME "fmi_host"
#define HOST_USAGE "[--stack BYTES] LIBRARY GUID [RESOURCES_URI]"
#define HOST_FUNCTIONS(X) \
    X(instantiate, fmi2Instantiate) X(free_instance, fmi2FreeInstance) X(setup, fmi2SetupExperiment) \
    X(enter, fmi2EnterInitializationMode) X(exit, fmi2ExitInitializationMode) X(terminate, fmi2Terminate) \
    X(reset, fmi2Reset) X(set_real, fmi2SetReal) X(set_integer, fmi2SetInteger) X(set_string, fmi2SetString) \
    X(get_real, fmi2GetReal) X(get_integer, fmi2GetInteger) X(get_string, fmi2GetString) X(do_step, fmi2DoStep) \
    X(get_state, fmi2GetFMUstate) X(set_state, fmi2SetFMUstate) X(free_state, fmi2FreeFMUstate) \
    X(state_size, fmi2SerializedFMUstateSize) X(serialize, fmi2SerializeFMUstate) \
    X(deserialize, fmi2DeSerializeFMUstate) X(directional_derivative, fmi2GetDirectionalDerivative)
typedef fmi2Component Instance;
typedef fmi2FMUstate State;
typedef fmi2ValueReference ValueReference;
typedef fmi2Integer Int32;
typedef fmi2String String;
typedef fmi2Byte Byte;
#define NVALUES(n)
#else
#error "HOST_FMI must be 2 or 3"
#endif

/* fmi2Status and fmi3Status number their values alike */
enum { STATUS_OK = 0, STATUS_WARNING = 1, STATUS_DISCARD = 2, STATUS_FATAL = 4 };

#define FUNCTION_FIELD(field, symbol) symbol##TYPE *field;
typedef struct {
    HOST_FUNCTIONS(FUNCTION_FIELD)
    const char *token;      /* the GUID (FMI 2.0) or instantiation token (FMI 3.0) */
    const char *resources;  /* "" when the FMU reads no resources */
    double start_time;      /* FMI 3.0: kept from setup for enter */
#if HOST_FMI == 2
    fmi2CallbackFunctions callbacks;
#endif
} Fmu;

#ifdef _WIN32
#include <windows.h>
static void *open_library(const char *path) { return (void *)LoadLibraryA(path); }
static void *symbol(void *lib, const char *name) { return (void *)GetProcAddress((HMODULE)lib, name); }
static double now(void) {
    LARGE_INTEGER f, c;
    QueryPerformanceFrequency(&f);
    QueryPerformanceCounter(&c);
    return (double)c.QuadPart / (double)f.QuadPart;
}
#else
#include <dlfcn.h>
#include <pthread.h>
#include <sys/mman.h>
#include <unistd.h>
static void *open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *symbol(void *lib, const char *name) { return dlsym(lib, name); }
static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
#endif

#if HOST_FMI == 3
static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    printf("log %d %s %s\n", (int)status, category, message);
}

static Instance instantiate(const Fmu *f, const char *name) {
    return f->instantiate(name, f->token, f->resources, fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0, NULL,
                          logger, NULL);
}

/* FMI 3.0 takes the start time on entering initialisation, FMI 2.0 in a call before */
static int setup(Fmu *f, Instance c, double t0) {
    (void)c;
    f->start_time = t0;
    return STATUS_OK;
}

static int enter(const Fmu *f, Instance c) {
    return (int)f->enter(c, fmi3False, 0.0, f->start_time, fmi3False, 0.0);
}

/* a step as the FMI 2.0 host takes it: the flags FMI 3.0 adds must all say "nothing happened" */
static int step(const Fmu *f, Instance c, double t, double h) {
    fmi3Boolean event = fmi3True, terminate = fmi3True, early = fmi3True;
    double last = -1.0;
    fmi3Status s = f->do_step(c, t, h, fmi3True, &event, &terminate, &early, &last);
    if (s <= fmi3Discard && (event || terminate || early)) {
        printf("flags %d %d %d\n", (int)event, (int)terminate, (int)early);
        return STATUS_FATAL;
    }
    if (s == fmi3OK && last != t + h) printf("last %.17g\n", last);
    return (int)s;
}
#else
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env; (void)name;
    printf("log %d %s %s\n", (int)status, category, message);
}

static Instance instantiate(const Fmu *f, const char *name) {
    return f->instantiate(name, fmi2CoSimulation, f->token, f->resources, &f->callbacks, fmi2False, fmi2False);
}

static int setup(Fmu *f, Instance c, double t0) {
    return (int)f->setup(c, fmi2False, 0.0, t0, fmi2False, 0.0);
}

static int enter(const Fmu *f, Instance c) { return (int)f->enter(c); }

static int step(const Fmu *f, Instance c, double t, double h) { return (int)f->do_step(c, t, h, fmi2True); }
#endif

/* the value references from p on, at most max of them: how many were read */
static int read_references(const char *p, ValueReference *vr, int max) {
    int m = 0, used;
    while (m < max && sscanf(p, "%u%n", &vr[m], &used) == 1) {
        m++;
        p += used;
    }
    return m;
}

#define LOAD(field, name) f.field = (name##TYPE *)symbol(lib, #name);
#define LINE_CHARS 65536

/* The script from stdin, one command a line. */
static void run_script(Fmu *fmu) {
    Fmu f = *fmu;
    Instance inst[16] = {0}, c = NULL;
    State saved[16] = {0};
    char *line = (char *)malloc(LINE_CHARS), cmd[64];  /* not on the stack: --stack measures the FMU's */
    if (line == NULL) return;
    while (fgets(line, LINE_CHARS, stdin)) {
        char *rest;
        int n = 0, k, s = STATUS_OK;
        if (sscanf(line, "%63s%n", cmd, &n) != 1) continue;
        rest = line + n;
        if (!strcmp(cmd, "new")) {
            char name[256];
            sscanf(rest, "%d %255s", &k, name);
            if (inst[k] != NULL) f.free_instance(inst[k]);  /* the slot's previous instance */
            c = inst[k] = instantiate(&f, name);
            printf("new %s\n", c ? "ok" : "null");
        } else if (!strcmp(cmd, "use")) {
            sscanf(rest, "%d", &k);
            c = inst[k];
            printf("use 0\n");
        } else if (!strcmp(cmd, "free")) {
            f.free_instance(c);
            for (k = 0; k < 16; k++) if (inst[k] == c) inst[k] = NULL;
            c = NULL;
            printf("free 0\n");
        } else if (!strcmp(cmd, "null")) {
            printf("null %d\n", step(&f, NULL, 0.0, 1e-3));
        } else if (!strcmp(cmd, "setup")) {
            double t0 = 0;
            sscanf(rest, "%lf", &t0);
            printf("setup %d\n", setup(&f, c, t0));
        } else if (!strcmp(cmd, "enter")) {
            printf("enter %d\n", enter(&f, c));
        } else if (!strcmp(cmd, "exit")) {
            printf("exit %d\n", (int)f.exit(c));
        } else if (!strcmp(cmd, "term")) {
            printf("term %d\n", (int)f.terminate(c));
        } else if (!strcmp(cmd, "reset")) {
            f.start_time = 0.0;
            printf("reset %d\n", (int)f.reset(c));
        } else if (!strcmp(cmd, "setr")) {
            ValueReference vr;
            double x;
            sscanf(rest, "%u %lf", &vr, &x);
            printf("setr %d\n", (int)f.set_real(c, &vr, 1, &x NVALUES(1)));
        } else if (!strcmp(cmd, "seti")) {
            ValueReference vr;
            Int32 x;
            sscanf(rest, "%u %d", &vr, &x);
            printf("seti %d\n", (int)f.set_integer(c, &vr, 1, &x NVALUES(1)));
#if HOST_FMI == 3
        } else if (!strcmp(cmd, "setl")) {
            fmi3ValueReference vr;
            long long x;
            fmi3Int64 y;
            sscanf(rest, "%u %lld", &vr, &x);
            y = (fmi3Int64)x;
            printf("setl %d\n", (int)f.set_int64(c, &vr, 1, &y, 1));
        } else if (!strcmp(cmd, "dropstate")) {  /* the state itself where its address belongs */
            sscanf(rest, "%d", &k);
            printf("dropstate %d\n", (int)f.free_state(c, (fmi3FMUState *)saved[k]));
            saved[k] = NULL;
#else
        } else if (!strcmp(cmd, "ddr")) {
            fmi2ValueReference known, vr[512];
            double seed = 1.0, v[512];
            int m, used;
            sscanf(rest, "%u%n", &known, &used);
            m = read_references(rest + used, vr, 512);
            s = (int)f.directional_derivative(c, vr, m, &known, 1, &seed, v);
            printf("ddr %d", s);
            for (k = 0; k < m && s <= STATUS_WARNING; k++) printf(" %.17g", v[k]);
            printf("\n");
#endif
        } else if (!strcmp(cmd, "sets")) {
            ValueReference vr;
            char text[4096] = "";
            String p = text;
            sscanf(rest, "%u %4095s", &vr, text);
            if (!strcmp(text, "-")) text[0] = '\0';  /* the empty string */
            printf("sets %d\n", (int)f.set_string(c, &vr, 1, &p NVALUES(1)));
        } else if (!strcmp(cmd, "getr") || !strcmp(cmd, "geti") || !strcmp(cmd, "gets")
                   || (HOST_FMI == 3 && !strcmp(cmd, "getl"))) {
            ValueReference vr[512];
            int m = read_references(rest, vr, 512);
            if (cmd[3] == 'r') {
                double v[512];
                s = (int)f.get_real(c, vr, m, v NVALUES(m));
                printf("getr %d", s);
                for (k = 0; k < m && s <= STATUS_WARNING; k++) printf(" %.17g", v[k]);
            } else if (cmd[3] == 'i') {
                Int32 v[512];
                s = (int)f.get_integer(c, vr, m, v NVALUES(m));
                printf("geti %d", s);
                for (k = 0; k < m && s <= STATUS_WARNING; k++) printf(" %d", (int)v[k]);
#if HOST_FMI == 3
            } else if (cmd[3] == 'l') {
                fmi3Int64 v[512];
                s = (int)f.get_int64(c, vr, m, v, m);
                printf("getl %d", s);
                for (k = 0; k < m && s <= STATUS_WARNING; k++) printf(" %lld", (long long)v[k]);
#endif
            } else {
                String v[512];
                s = (int)f.get_string(c, vr, m, v NVALUES(m));
                printf("gets %d", s);
                for (k = 0; k < m && s <= STATUS_WARNING; k++) printf(" [%s]", v[k]);
            }
            printf("\n");
        } else if (!strcmp(cmd, "step")) {
            double t, h;
            sscanf(rest, "%lf %lf", &t, &h);
            printf("step %d\n", step(&f, c, t, h));
        } else if (!strcmp(cmd, "run")) {
            double t, h, v[512];
            int steps, m, used, i;
            ValueReference vr[512];
            sscanf(rest, "%lf %lf %d%n", &t, &h, &steps, &used);
            m = read_references(rest + used, vr, 512);
            for (i = 0; i < steps && s == STATUS_OK; i++) {
                s = step(&f, c, t + i * h, h);
                if (s == STATUS_OK) s = (int)f.get_real(c, vr, m, v NVALUES(m));
                if (s != STATUS_OK) break;
                printf("row %.17g", t + (i + 1) * h);
                for (k = 0; k < m; k++) printf(" %.17g", v[k]);
                printf("\n");
            }
            printf("run %d\n", s);
        } else if (!strcmp(cmd, "save")) {
            sscanf(rest, "%d", &k);
            printf("save %d\n", (int)f.get_state(c, &saved[k]));
        } else if (!strcmp(cmd, "load")) {
            sscanf(rest, "%d", &k);
            printf("load %d\n", (int)f.set_state(c, saved[k]));
        } else if (!strcmp(cmd, "drop")) {
            sscanf(rest, "%d", &k);
            printf("drop %d\n", (int)f.free_state(c, &saved[k]));
        } else if (!strcmp(cmd, "ser")) {
            char path[4096];
            size_t size = 0;
            sscanf(rest, "%d %4095s", &k, path);
            s = (int)f.state_size(c, saved[k], &size);
            if (s == STATUS_OK) {
                Byte *b = (Byte *)malloc(size);
                s = (int)f.serialize(c, saved[k], b, size);
                if (s == STATUS_OK) {
                    FILE *out = fopen(path, "wb");
                    if (out != NULL) {
                        fwrite(b, 1, size, out);
                        fclose(out);
                    }
                }
                free(b);
            }
            printf("ser %d %u\n", s, (unsigned)size);
        } else if (!strcmp(cmd, "deser")) {
            char path[4096];
            long size;
            Byte *b;
            FILE *in;
            sscanf(rest, "%d %4095s", &k, path);
            in = fopen(path, "rb");
            if (in == NULL) {
                printf("deser nofile\n");
                fflush(stdout);
                continue;
            }
            fseek(in, 0, SEEK_END);
            size = ftell(in);
            fseek(in, 0, SEEK_SET);
            b = (Byte *)malloc(size > 0 ? (size_t)size : 1);
            if (fread(b, 1, (size_t)size, in) != (size_t)size) size = 0;
            fclose(in);
            printf("deser %d\n", (int)f.deserialize(c, b, (size_t)size, &saved[k]));
            free(b);
        } else if (!strcmp(cmd, "bench")) {
            double t, h, u = 0.0, v[8], t0;
            int steps, m, used, i;
            ValueReference in, vr[8];
            sscanf(rest, "%d %lf %lf %u%n", &steps, &t, &h, &in, &used);
            m = read_references(rest + used, vr, 8);
            t0 = now();
            for (i = 0; i < steps && s == STATUS_OK; i++) {
                u = 0.5 * (i % 7);
                s = (int)f.set_real(c, &in, 1, &u NVALUES(1));
                if (s == STATUS_OK) s = step(&f, c, t + i * h, h);
                if (s == STATUS_OK) s = (int)f.get_real(c, vr, m, v NVALUES(m));
            }
            printf("bench %d %.1f\n", s, 1e9 * (now() - t0) / steps);
        } else {
            printf("%s unknown\n", cmd);
        }
        fflush(stdout);
    }
    {  /* states first, through a live instance (a fresh one if none is left), then the instances */
        int j, k, left = 0;
        Instance any = NULL;
        for (k = 0; k < 16; k++) if (inst[k] != NULL) any = inst[k];
        for (j = 0; j < 16; j++) left |= saved[j] != NULL;
        if (left && any == NULL) any = inst[0] = instantiate(&f, "cleanup");
        for (j = 0; j < 16 && any != NULL; j++)
            if (saved[j]) f.free_state(any, &saved[j]);
        for (k = 0; k < 16; k++) {
            if (inst[k] == NULL) continue;
            f.free_instance(inst[k]);
            for (j = k + 1; j < 16; j++) if (inst[j] == inst[k]) inst[j] = NULL;
        }
    }
    free(line);
}

#ifndef _WIN32
#define PAINT 0xA5

static void *script_thread(void *fmu) {
    run_script((Fmu *)fmu);
    return NULL;
}

/* The script on a thread with a stack of `bytes` (rounded up to pages) above
 * a guard page; the bytes of the stack the run touched, or -1 if no such
 * thread could be made.  Stacks grow down on every platform the FMUs ship for. */
static long run_on_stack(Fmu *f, size_t bytes) {
    size_t page = (size_t)sysconf(_SC_PAGESIZE), size = (bytes + page - 1) / page * page, k;
    void *mem = NULL;
    unsigned char *stack;
    pthread_attr_t attr;
    pthread_t thread;
    int made;
    if (posix_memalign(&mem, page, size + page) != 0) return -1;
    stack = (unsigned char *)mem + page;
    memset(stack, PAINT, size);
    if (mprotect(mem, page, PROT_NONE) != 0) {
        free(mem);
        return -1;
    }
    pthread_attr_init(&attr);
    made = pthread_attr_setstack(&attr, stack, size) == 0 && pthread_create(&thread, &attr, script_thread, f) == 0;
    pthread_attr_destroy(&attr);
    if (made) pthread_join(thread, NULL);
    for (k = 0; k < size && stack[k] == PAINT; k++) continue;
    mprotect(mem, page, PROT_READ | PROT_WRITE);
    free(mem);
    return made ? (long)(size - k) : -1;
}
#endif

int main(int argc, char **argv) {
    void *lib;
    Fmu f;
    long stack = 0, asked = 0;
    if (argc > 2 && !strcmp(argv[1], "--stack")) {
        stack = asked = atol(argv[2]);
        argc -= 2;
        argv += 2;
    }
    if ((argc != 3 && !(HOST_FMI == 2 && argc == 4)) || stack < 0) {
        fprintf(stderr, "usage: " HOST_NAME " " HOST_USAGE " < script\n");
        return 2;
    }
    lib = open_library(argv[1]);
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s\n", argv[1]);
        return 2;
    }
    memset(&f, 0, sizeof f);
    HOST_FUNCTIONS(LOAD)
    f.token = argv[2];
    f.resources = argc == 4 ? argv[3] : "";
#if HOST_FMI == 3
    if (!f.instantiate || !f.do_step || !f.deserialize || !f.get_int64) {
#else
    f.callbacks.logger = logger;
    f.callbacks.allocateMemory = calloc;
    f.callbacks.freeMemory = free;
    if (!f.instantiate || !f.do_step || !f.deserialize) {
#endif
        fprintf(stderr, "missing fmi%d symbols\n", HOST_FMI);
        return 2;
    }
    if (stack == 0) {
        run_script(&f);
        return 0;
    }
#ifdef _WIN32
    fprintf(stderr, "--stack: POSIX threads only\n");
    return 2;
#else
    stack = run_on_stack(&f, (size_t)stack);
    if (stack < 0) {
        fprintf(stderr, "cannot make a thread with a stack of %ld bytes\n", asked);
        return 2;
    }
    printf("stack %ld\n", stack);
    return 0;
#endif
}
