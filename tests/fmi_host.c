/* A minimal FMI 2.0 co-simulation host for the tests: no Python in the process.
 *
 *     fmi_host LIBRARY GUID [RESOURCES_URI] < script
 *
 * (RESOURCES_URI, e.g. file:///tmp/x/resources, for an FMU that reads its
 * resources: the container FMU of a system) loads the FMU's binary (dlopen, or LoadLibrary when built with MinGW) and runs
 * a script of one command per line, printing one line per command:
 * "<command> <status> [values]"; the FMU's log lines come as "log <status>
 * <category> <message>".  Commands:
 *
 *   new K NAME      instantiate into slot K (0..15) and use it    use K
 *   setup T0 | enter | exit | term | reset | free
 *   setr VR X | seti VR N | sets VR TEXT | getr VR... | geti VR... | gets VR...
 *   step T H        fmi2DoStep(T, H)
 *   run T H N VR... N steps of H from T, a "row t values" line after each
 *   save K | load K | drop K           fmi2GetFMUstate / SetFMUstate / FreeFMUstate in state slot K
 *   ser K FILE | deser K FILE          serialise state slot K to a file / from a file into slot K
 *   bench N T H VRIN VROUT...          N x (setReal VRIN, doStep, getReal VROUT...): ns per step
 *   ddr VRIN VROUT...                  fmi2GetDirectionalDerivative of the outputs along input VRIN (seed 1)
 *   null            call fmi2DoStep on a NULL instance (must not crash)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdarg.h>
#include <time.h>

#include "fmi2Functions.h"

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
static void *open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *symbol(void *lib, const char *name) { return dlsym(lib, name); }
static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
#endif

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env; (void)name;
    printf("log %d %s %s\n", (int)status, category, message);
}

#define LOAD(f) f##TYPE *f = (f##TYPE *)symbol(lib, #f)

int main(int argc, char **argv) {
    void *lib;
    fmi2Component inst[16] = {0}, c = NULL;
    fmi2FMUstate saved[16] = {0};
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    char line[65536], cmd[64];
    const char *resources = argc == 4 ? argv[3] : "";
    if (argc != 3 && argc != 4) {
        fprintf(stderr, "usage: fmi_host LIBRARY GUID [RESOURCES_URI] < script\n");
        return 2;
    }
    lib = open_library(argv[1]);
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s\n", argv[1]);
        return 2;
    }
    {
        LOAD(fmi2Instantiate); LOAD(fmi2FreeInstance); LOAD(fmi2SetupExperiment);
        LOAD(fmi2EnterInitializationMode); LOAD(fmi2ExitInitializationMode); LOAD(fmi2Terminate); LOAD(fmi2Reset);
        LOAD(fmi2SetReal); LOAD(fmi2SetInteger); LOAD(fmi2SetString); LOAD(fmi2GetReal); LOAD(fmi2GetInteger);
        LOAD(fmi2GetString); LOAD(fmi2DoStep); LOAD(fmi2GetFMUstate); LOAD(fmi2SetFMUstate); LOAD(fmi2FreeFMUstate);
        LOAD(fmi2SerializedFMUstateSize); LOAD(fmi2SerializeFMUstate); LOAD(fmi2DeSerializeFMUstate);
        LOAD(fmi2GetDirectionalDerivative);
        if (!fmi2Instantiate || !fmi2DoStep || !fmi2DeSerializeFMUstate) {
            fprintf(stderr, "missing fmi2 symbols\n");
            return 2;
        }
        while (fgets(line, sizeof line, stdin)) {
            char *rest;
            int n = 0, k;
            fmi2Status s = fmi2OK;
            if (sscanf(line, "%63s%n", cmd, &n) != 1) continue;
            rest = line + n;
            if (!strcmp(cmd, "new")) {
                char name[256];
                sscanf(rest, "%d %255s", &k, name);
                if (inst[k] != NULL) fmi2FreeInstance(inst[k]);  /* the slot's previous instance */
                c = inst[k] = fmi2Instantiate(name, fmi2CoSimulation, argv[2], resources, &cb, fmi2False, fmi2False);
                printf("new %s\n", c ? "ok" : "null");
            } else if (!strcmp(cmd, "use")) {
                sscanf(rest, "%d", &k);
                c = inst[k];
                printf("use 0\n");
            } else if (!strcmp(cmd, "free")) {
                fmi2FreeInstance(c);
                for (k = 0; k < 16; k++) if (inst[k] == c) inst[k] = NULL;
                c = NULL;
                printf("free 0\n");
            } else if (!strcmp(cmd, "null")) {
                printf("null %d\n", (int)fmi2DoStep(NULL, 0.0, 1e-3, fmi2True));
            } else if (!strcmp(cmd, "setup")) {
                double t0 = 0;
                sscanf(rest, "%lf", &t0);
                printf("setup %d\n", (int)fmi2SetupExperiment(c, fmi2False, 0.0, t0, fmi2False, 0.0));
            } else if (!strcmp(cmd, "enter")) {
                printf("enter %d\n", (int)fmi2EnterInitializationMode(c));
            } else if (!strcmp(cmd, "exit")) {
                printf("exit %d\n", (int)fmi2ExitInitializationMode(c));
            } else if (!strcmp(cmd, "term")) {
                printf("term %d\n", (int)fmi2Terminate(c));
            } else if (!strcmp(cmd, "reset")) {
                printf("reset %d\n", (int)fmi2Reset(c));
            } else if (!strcmp(cmd, "setr")) {
                fmi2ValueReference vr;
                double x;
                sscanf(rest, "%u %lf", &vr, &x);
                printf("setr %d\n", (int)fmi2SetReal(c, &vr, 1, &x));
            } else if (!strcmp(cmd, "seti")) {
                fmi2ValueReference vr;
                int x;
                sscanf(rest, "%u %d", &vr, &x);
                printf("seti %d\n", (int)fmi2SetInteger(c, &vr, 1, &x));
            } else if (!strcmp(cmd, "sets")) {
                fmi2ValueReference vr;
                char text[4096] = "";
                const char *p = text;
                sscanf(rest, "%u %4095s", &vr, text);
                if (!strcmp(text, "-")) text[0] = '\0';  /* the empty string */
                printf("sets %d\n", (int)fmi2SetString(c, &vr, 1, &p));
            } else if (!strcmp(cmd, "getr") || !strcmp(cmd, "geti") || !strcmp(cmd, "gets")) {
                fmi2ValueReference vr[512];
                int m = 0, used;
                char *p = rest;
                while (m < 512 && sscanf(p, "%u%n", &vr[m], &used) == 1) {
                    m++;
                    p += used;
                }
                if (cmd[3] == 'r') {
                    double v[512];
                    s = fmi2GetReal(c, vr, m, v);
                    printf("getr %d", (int)s);
                    for (k = 0; k < m && s <= fmi2Warning; k++) printf(" %.17g", v[k]);
                } else if (cmd[3] == 'i') {
                    int v[512];
                    s = fmi2GetInteger(c, vr, m, v);
                    printf("geti %d", (int)s);
                    for (k = 0; k < m && s <= fmi2Warning; k++) printf(" %d", v[k]);
                } else {
                    fmi2String v[512];
                    s = fmi2GetString(c, vr, m, v);
                    printf("gets %d", (int)s);
                    for (k = 0; k < m && s <= fmi2Warning; k++) printf(" [%s]", v[k]);
                }
                printf("\n");
            } else if (!strcmp(cmd, "ddr")) {
                fmi2ValueReference known, vr[512];
                double seed = 1.0, v[512];
                int m = 0, used;
                char *p = rest;
                sscanf(p, "%u%n", &known, &used);
                p += used;
                while (m < 512 && sscanf(p, "%u%n", &vr[m], &used) == 1) {
                    m++;
                    p += used;
                }
                s = fmi2GetDirectionalDerivative(c, vr, m, &known, 1, &seed, v);
                printf("ddr %d", (int)s);
                for (k = 0; k < m && s <= fmi2Warning; k++) printf(" %.17g", v[k]);
                printf("\n");
            } else if (!strcmp(cmd, "step")) {
                double t, h;
                sscanf(rest, "%lf %lf", &t, &h);
                printf("step %d\n", (int)fmi2DoStep(c, t, h, fmi2True));
            } else if (!strcmp(cmd, "run")) {
                double t, h, v[512];
                int steps, m = 0, used, i;
                fmi2ValueReference vr[512];
                char *p = rest;
                sscanf(p, "%lf %lf %d%n", &t, &h, &steps, &used);
                p += used;
                while (m < 512 && sscanf(p, "%u%n", &vr[m], &used) == 1) {
                    m++;
                    p += used;
                }
                for (i = 0; i < steps && s == fmi2OK; i++) {
                    s = fmi2DoStep(c, t + i * h, h, fmi2True);
                    if (s == fmi2OK) s = fmi2GetReal(c, vr, m, v);
                    if (s != fmi2OK) break;
                    printf("row %.17g", t + (i + 1) * h);
                    for (k = 0; k < m; k++) printf(" %.17g", v[k]);
                    printf("\n");
                }
                printf("run %d\n", (int)s);
            } else if (!strcmp(cmd, "save")) {
                sscanf(rest, "%d", &k);
                printf("save %d\n", (int)fmi2GetFMUstate(c, &saved[k]));
            } else if (!strcmp(cmd, "load")) {
                sscanf(rest, "%d", &k);
                printf("load %d\n", (int)fmi2SetFMUstate(c, saved[k]));
            } else if (!strcmp(cmd, "drop")) {
                sscanf(rest, "%d", &k);
                printf("drop %d\n", (int)fmi2FreeFMUstate(c, &saved[k]));
            } else if (!strcmp(cmd, "ser")) {
                char path[4096];
                size_t size = 0;
                sscanf(rest, "%d %4095s", &k, path);
                s = fmi2SerializedFMUstateSize(c, saved[k], &size);
                if (s == fmi2OK) {
                    fmi2Byte *b = (fmi2Byte *)malloc(size);
                    s = fmi2SerializeFMUstate(c, saved[k], b, size);
                    if (s == fmi2OK) {
                        FILE *f = fopen(path, "wb");
                        if (f != NULL) {
                            fwrite(b, 1, size, f);
                            fclose(f);
                        }
                    }
                    free(b);
                }
                printf("ser %d %u\n", (int)s, (unsigned)size);
            } else if (!strcmp(cmd, "deser")) {
                char path[4096];
                long size;
                fmi2Byte *b;
                FILE *f;
                sscanf(rest, "%d %4095s", &k, path);
                f = fopen(path, "rb");
                if (f == NULL) {
                    printf("deser nofile\n");
                    fflush(stdout);
                    continue;
                }
                fseek(f, 0, SEEK_END);
                size = ftell(f);
                fseek(f, 0, SEEK_SET);
                b = (fmi2Byte *)malloc(size > 0 ? (size_t)size : 1);
                if (fread(b, 1, (size_t)size, f) != (size_t)size) size = 0;
                fclose(f);
                printf("deser %d\n", (int)fmi2DeSerializeFMUstate(c, b, (size_t)size, &saved[k]));
                free(b);
            } else if (!strcmp(cmd, "bench")) {
                double t, h, u = 0.0, v[8], t0;
                int steps, m = 0, used, i;
                fmi2ValueReference in, vr[8];
                char *p = rest;
                sscanf(p, "%d %lf %lf %u%n", &steps, &t, &h, &in, &used);
                p += used;
                while (m < 8 && sscanf(p, "%u%n", &vr[m], &used) == 1) {
                    m++;
                    p += used;
                }
                t0 = now();
                for (i = 0; i < steps && s == fmi2OK; i++) {
                    u = 0.5 * (i % 7);
                    s = fmi2SetReal(c, &in, 1, &u);
                    if (s == fmi2OK) s = fmi2DoStep(c, t + i * h, h, fmi2True);
                    if (s == fmi2OK) s = fmi2GetReal(c, vr, m, v);
                }
                printf("bench %d %.1f\n", (int)s, 1e9 * (now() - t0) / steps);
            } else {
                printf("%s unknown\n", cmd);
            }
            fflush(stdout);
        }
        {  /* states first, through a live instance (a fresh one if none is left), then the instances */
            int j, k, left = 0;
            fmi2Component any = NULL;
            for (k = 0; k < 16; k++) if (inst[k] != NULL) any = inst[k];
            for (j = 0; j < 16; j++) left |= saved[j] != NULL;
            if (left && any == NULL)
                any = inst[0] = fmi2Instantiate("cleanup", fmi2CoSimulation, argv[2], resources, &cb, fmi2False, fmi2False);
            for (j = 0; j < 16 && any != NULL; j++)
                if (saved[j]) fmi2FreeFMUstate(any, &saved[j]);
            for (k = 0; k < 16; k++) {
                if (inst[k] == NULL) continue;
                fmi2FreeInstance(inst[k]);
                for (j = k + 1; j < 16; j++) if (inst[j] == inst[k]) inst[j] = NULL;
            }
        }
    }
    return 0;
}
