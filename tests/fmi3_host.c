/* A minimal FMI 3.0 co-simulation host for the tests: no Python in the process.
 * The FMI 3.0 twin of fmi_host.c, with the same script language and the same
 * output, so one script runs an FMU's FMI 2.0 and FMI 3.0 builds alike.
 *
 *     fmi3_host LIBRARY INSTANTIATION_TOKEN < script
 *
 * loads the FMU's binary (dlopen, or LoadLibrary when built with MinGW) and runs
 * a script of one command per line, printing one line per command:
 * "<command> <status> [values]"; the FMU's log lines come as "log <status>
 * <category> <message>".  Commands:
 *
 *   new K NAME      instantiate into slot K (0..15) and use it    use K
 *   setup T0 | enter | exit | term | reset | free   (setup keeps T0 for enter:
 *                   fmi3EnterInitializationMode takes the start time)
 *   setr VR X | seti VR N | sets VR TEXT | getr VR... | geti VR... | gets VR...
 *   setl VR N | getl VR...            Int64 (an enumeration)
 *   step T H        fmi3DoStep(T, H)
 *   run T H N VR... N steps of H from T, a "row t values" line after each
 *   dropstate K     fmi3FreeFMUState given the state itself, not its address (fmusim 0.0.39's mistake)
 *   save K | load K | drop K           fmi3GetFMUState / SetFMUState / FreeFMUState in state slot K
 *   ser K FILE | deser K FILE          serialise state slot K to a file / from a file into slot K
 *   bench N T H VRIN VROUT...          N x (setReal VRIN, doStep, getReal VROUT...): ns per step
 *   null            call fmi3DoStep on a NULL instance (must not crash)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdarg.h>
#include <time.h>

#include "fmi3Functions.h"

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

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    printf("log %d %s %s\n", (int)status, category, message);
}

/* a step as the FMI 2.0 host takes it: the flags FMI 3.0 adds must all say "nothing happened" */
static fmi3Status step(fmi3DoStepTYPE *fmi3DoStep, fmi3Instance c, double t, double h) {
    fmi3Boolean event = fmi3True, terminate = fmi3True, early = fmi3True;
    double last = -1.0;
    fmi3Status s = fmi3DoStep(c, t, h, fmi3True, &event, &terminate, &early, &last);
    if (s <= fmi3Discard && (event || terminate || early)) {
        printf("flags %d %d %d\n", (int)event, (int)terminate, (int)early);
        return fmi3Fatal;
    }
    if (s == fmi3OK && last != t + h) printf("last %.17g\n", last);
    return s;
}

#define LOAD(f) f##TYPE *f = (f##TYPE *)symbol(lib, #f)

int main(int argc, char **argv) {
    void *lib;
    fmi3Instance inst[16] = {0}, c = NULL;
    fmi3FMUState saved[16] = {0};
    double start_time = 0.0;
    char line[65536], cmd[64];
    if (argc != 3) {
        fprintf(stderr, "usage: fmi3_host LIBRARY INSTANTIATION_TOKEN < script\n");
        return 2;
    }
    lib = open_library(argv[1]);
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s\n", argv[1]);
        return 2;
    }
    {
        LOAD(fmi3InstantiateCoSimulation); LOAD(fmi3FreeInstance);
        LOAD(fmi3EnterInitializationMode); LOAD(fmi3ExitInitializationMode); LOAD(fmi3Terminate); LOAD(fmi3Reset);
        LOAD(fmi3SetFloat64); LOAD(fmi3SetInt32); LOAD(fmi3SetInt64); LOAD(fmi3SetString); LOAD(fmi3GetFloat64);
        LOAD(fmi3GetInt32); LOAD(fmi3GetInt64); LOAD(fmi3GetString); LOAD(fmi3DoStep); LOAD(fmi3GetFMUState);
        LOAD(fmi3SetFMUState); LOAD(fmi3FreeFMUState); LOAD(fmi3SerializedFMUStateSize); LOAD(fmi3SerializeFMUState);
        LOAD(fmi3DeserializeFMUState);
        if (!fmi3InstantiateCoSimulation || !fmi3DoStep || !fmi3DeserializeFMUState || !fmi3GetInt64) {
            fprintf(stderr, "missing fmi3 symbols\n");
            return 2;
        }
        while (fgets(line, sizeof line, stdin)) {
            char *rest;
            int n = 0, k;
            fmi3Status s = fmi3OK;
            if (sscanf(line, "%63s%n", cmd, &n) != 1) continue;
            rest = line + n;
            if (!strcmp(cmd, "new")) {
                char name[256];
                sscanf(rest, "%d %255s", &k, name);
                if (inst[k] != NULL) fmi3FreeInstance(inst[k]);  /* the slot's previous instance */
                c = inst[k] = fmi3InstantiateCoSimulation(name, argv[2], "", fmi3False, fmi3False, fmi3False, fmi3False,
                                                          NULL, 0, NULL, logger, NULL);
                printf("new %s\n", c ? "ok" : "null");
            } else if (!strcmp(cmd, "use")) {
                sscanf(rest, "%d", &k);
                c = inst[k];
                printf("use 0\n");
            } else if (!strcmp(cmd, "free")) {
                fmi3FreeInstance(c);
                for (k = 0; k < 16; k++) if (inst[k] == c) inst[k] = NULL;
                c = NULL;
                printf("free 0\n");
            } else if (!strcmp(cmd, "null")) {
                printf("null %d\n", (int)step(fmi3DoStep, NULL, 0.0, 1e-3));
            } else if (!strcmp(cmd, "setup")) {
                start_time = 0;
                sscanf(rest, "%lf", &start_time);
                printf("setup 0\n");
            } else if (!strcmp(cmd, "enter")) {
                printf("enter %d\n", (int)fmi3EnterInitializationMode(c, fmi3False, 0.0, start_time, fmi3False, 0.0));
            } else if (!strcmp(cmd, "exit")) {
                printf("exit %d\n", (int)fmi3ExitInitializationMode(c));
            } else if (!strcmp(cmd, "term")) {
                printf("term %d\n", (int)fmi3Terminate(c));
            } else if (!strcmp(cmd, "reset")) {
                start_time = 0.0;
                printf("reset %d\n", (int)fmi3Reset(c));
            } else if (!strcmp(cmd, "setr")) {
                fmi3ValueReference vr;
                double x;
                sscanf(rest, "%u %lf", &vr, &x);
                printf("setr %d\n", (int)fmi3SetFloat64(c, &vr, 1, &x, 1));
            } else if (!strcmp(cmd, "seti")) {
                fmi3ValueReference vr;
                fmi3Int32 x;
                sscanf(rest, "%u %d", &vr, &x);
                printf("seti %d\n", (int)fmi3SetInt32(c, &vr, 1, &x, 1));
            } else if (!strcmp(cmd, "setl")) {
                fmi3ValueReference vr;
                long long x;
                fmi3Int64 y;
                sscanf(rest, "%u %lld", &vr, &x);
                y = (fmi3Int64)x;
                printf("setl %d\n", (int)fmi3SetInt64(c, &vr, 1, &y, 1));
            } else if (!strcmp(cmd, "sets")) {
                fmi3ValueReference vr;
                char text[4096] = "";
                const char *p = text;
                sscanf(rest, "%u %4095s", &vr, text);
                if (!strcmp(text, "-")) text[0] = '\0';  /* the empty string */
                printf("sets %d\n", (int)fmi3SetString(c, &vr, 1, &p, 1));
            } else if (!strcmp(cmd, "getr") || !strcmp(cmd, "geti") || !strcmp(cmd, "getl") || !strcmp(cmd, "gets")) {
                fmi3ValueReference vr[512];
                int m = 0, used;
                char *p = rest;
                while (m < 512 && sscanf(p, "%u%n", &vr[m], &used) == 1) {
                    m++;
                    p += used;
                }
                if (cmd[3] == 'r') {
                    double v[512];
                    s = fmi3GetFloat64(c, vr, m, v, m);
                    printf("getr %d", (int)s);
                    for (k = 0; k < m && s <= fmi3Warning; k++) printf(" %.17g", v[k]);
                } else if (cmd[3] == 'i') {
                    fmi3Int32 v[512];
                    s = fmi3GetInt32(c, vr, m, v, m);
                    printf("geti %d", (int)s);
                    for (k = 0; k < m && s <= fmi3Warning; k++) printf(" %d", (int)v[k]);
                } else if (cmd[3] == 'l') {
                    fmi3Int64 v[512];
                    s = fmi3GetInt64(c, vr, m, v, m);
                    printf("getl %d", (int)s);
                    for (k = 0; k < m && s <= fmi3Warning; k++) printf(" %lld", (long long)v[k]);
                } else {
                    fmi3String v[512];
                    s = fmi3GetString(c, vr, m, v, m);
                    printf("gets %d", (int)s);
                    for (k = 0; k < m && s <= fmi3Warning; k++) printf(" [%s]", v[k]);
                }
                printf("\n");
            } else if (!strcmp(cmd, "step")) {
                double t, h;
                sscanf(rest, "%lf %lf", &t, &h);
                printf("step %d\n", (int)step(fmi3DoStep, c, t, h));
            } else if (!strcmp(cmd, "run")) {
                double t, h, v[512];
                int steps, m = 0, used, i;
                fmi3ValueReference vr[512];
                char *p = rest;
                sscanf(p, "%lf %lf %d%n", &t, &h, &steps, &used);
                p += used;
                while (m < 512 && sscanf(p, "%u%n", &vr[m], &used) == 1) {
                    m++;
                    p += used;
                }
                for (i = 0; i < steps && s == fmi3OK; i++) {
                    s = step(fmi3DoStep, c, t + i * h, h);
                    if (s == fmi3OK) s = fmi3GetFloat64(c, vr, m, v, m);
                    if (s != fmi3OK) break;
                    printf("row %.17g", t + (i + 1) * h);
                    for (k = 0; k < m; k++) printf(" %.17g", v[k]);
                    printf("\n");
                }
                printf("run %d\n", (int)s);
            } else if (!strcmp(cmd, "save")) {
                sscanf(rest, "%d", &k);
                printf("save %d\n", (int)fmi3GetFMUState(c, &saved[k]));
            } else if (!strcmp(cmd, "load")) {
                sscanf(rest, "%d", &k);
                printf("load %d\n", (int)fmi3SetFMUState(c, saved[k]));
            } else if (!strcmp(cmd, "drop")) {
                sscanf(rest, "%d", &k);
                printf("drop %d\n", (int)fmi3FreeFMUState(c, &saved[k]));
            } else if (!strcmp(cmd, "dropstate")) {  /* the state itself where its address belongs */
                sscanf(rest, "%d", &k);
                printf("dropstate %d\n", (int)fmi3FreeFMUState(c, (fmi3FMUState *)saved[k]));
                saved[k] = NULL;
            } else if (!strcmp(cmd, "ser")) {
                char path[4096];
                size_t size = 0;
                sscanf(rest, "%d %4095s", &k, path);
                s = fmi3SerializedFMUStateSize(c, saved[k], &size);
                if (s == fmi3OK) {
                    fmi3Byte *b = (fmi3Byte *)malloc(size);
                    s = fmi3SerializeFMUState(c, saved[k], b, size);
                    if (s == fmi3OK) {
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
                fmi3Byte *b;
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
                b = (fmi3Byte *)malloc(size > 0 ? (size_t)size : 1);
                if (fread(b, 1, (size_t)size, f) != (size_t)size) size = 0;
                fclose(f);
                printf("deser %d\n", (int)fmi3DeserializeFMUState(c, b, (size_t)size, &saved[k]));
                free(b);
            } else if (!strcmp(cmd, "bench")) {
                double t, h, u = 0.0, v[8], t0;
                int steps, m = 0, used, i;
                fmi3ValueReference in, vr[8];
                char *p = rest;
                sscanf(p, "%d %lf %lf %u%n", &steps, &t, &h, &in, &used);
                p += used;
                while (m < 8 && sscanf(p, "%u%n", &vr[m], &used) == 1) {
                    m++;
                    p += used;
                }
                t0 = now();
                for (i = 0; i < steps && s == fmi3OK; i++) {
                    u = 0.5 * (i % 7);
                    s = fmi3SetFloat64(c, &in, 1, &u, 1);
                    if (s == fmi3OK) s = step(fmi3DoStep, c, t + i * h, h);
                    if (s == fmi3OK) s = fmi3GetFloat64(c, vr, m, v, m);
                }
                printf("bench %d %.1f\n", (int)s, 1e9 * (now() - t0) / steps);
            } else {
                printf("%s unknown\n", cmd);
            }
            fflush(stdout);
        }
        {  /* states first, through a live instance (a fresh one if none is left), then the instances */
            int j, k, left = 0;
            fmi3Instance any = NULL;
            for (k = 0; k < 16; k++) if (inst[k] != NULL) any = inst[k];
            for (j = 0; j < 16; j++) left |= saved[j] != NULL;
            if (left && any == NULL)
                any = inst[0] = fmi3InstantiateCoSimulation("cleanup", argv[2], "", fmi3False, fmi3False, fmi3False,
                                                            fmi3False, NULL, 0, NULL, logger, NULL);
            for (j = 0; j < 16 && any != NULL; j++)
                if (saved[j]) fmi3FreeFMUState(any, &saved[j]);
            for (k = 0; k < 16; k++) {
                if (inst[k] == NULL) continue;
                fmi3FreeInstance(inst[k]);
                for (j = k + 1; j < 16; j++) if (inst[j] == inst[k]) inst[j] = NULL;
            }
        }
    }
    return 0;
}
