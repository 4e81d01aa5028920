/* sources.c — the kernel sources of a handle: read from a directory, from strings or from the
 * copy built into the library, with local includes expanded as the Python host does
 * (oclshade/runtime.py kernel_source). */
#include "internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_INCLUDES 16

/* ------------------------------------------------------------------ sources */

typedef struct strbuf {
    char *p;
    size_t len, cap;
    int oom;
} strbuf;

static void sb_append(strbuf *b, const char *s, size_t n)
{
    if (b->oom) return;
    if (b->len + n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->len + n + 1) cap *= 2;
        char *p = (char *)realloc(b->p, cap);
        if (p == NULL) { b->oom = 1; return; }
        b->p = p;
        b->cap = cap;
    }
    memcpy(b->p + b->len, s, n);
    b->len += n;
    b->p[b->len] = '\0';
}

#define SOURCE_FILES "common.h, pyramid.cl, shadow.cl, terrain.cl, ssao.cl, compose.cl, sunshine.cl, horizon.cl, cubemap.h, envmap.cl, quadric.cl and reflect.cl"

/* The text of a source file (malloc'd) into *text. */
static oclshade_status load_source(oclshade *lib, const source_set *set, const char *name, char **text_out)
{
    if (set->dir == NULL) {
        for (size_t i = 0; i < set->count; ++i) {
            if (set->list[i].name != NULL && strcmp(set->list[i].name, name) == 0) {
                if (set->list[i].text == NULL) break;
                size_t n = strlen(set->list[i].text);
                char *copy = (char *)malloc(n + 1);
                if (copy == NULL) return ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "out of memory copying %s", name);
                memcpy(copy, set->list[i].text, n + 1);
                *text_out = copy;
                return OCLSHADE_OK;
            }
        }
        return ocls_fail(lib, OCLSHADE_SOURCE_ERROR, 0, "kernel source \"%s\" is not among the %lu sources given "
                         "(expected " SOURCE_FILES " with non-NULL text)", name, (unsigned long)set->count);
    }
    size_t dlen = strlen(set->dir);
    char *path = (char *)malloc(dlen + strlen(name) + 2);
    if (path == NULL) return ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "out of memory");
    sprintf(path, "%s%s%s", set->dir, (dlen && (set->dir[dlen - 1] == '/' || set->dir[dlen - 1] == '\\')) ? "" : "/", name);
    FILE *f = fopen(path, "rb");
    char *text = NULL;
    long size = -1;
    if (f != NULL && fseek(f, 0, SEEK_END) == 0 && (size = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0) {
        text = (char *)malloc((size_t)size + 1);
        if (text != NULL && fread(text, 1, (size_t)size, f) == (size_t)size) {
            text[size] = '\0';
        } else {
            free(text);
            text = NULL;
        }
    }
    if (f != NULL) fclose(f);
    oclshade_status st = OCLSHADE_OK;
    if (text == NULL)
        st = ocls_fail(lib, OCLSHADE_SOURCE_ERROR, 0, "cannot read kernel source %s (kernel_dir must hold "
                       SOURCE_FILES ": the repository's kernels/ or the Python package's oclshade/kernels)", path);
    free(path);
    *text_out = text;
    return st;
}

/* If line [s, e) is `#include "name"` (blanks allowed around the tokens),
 * copy the name into out and return 1. */
static int include_line(const char *s, const char *e, char *out, size_t out_size)
{
    while (s < e && (*s == ' ' || *s == '\t')) ++s;
    if (s == e || *s++ != '#') return 0;
    while (s < e && (*s == ' ' || *s == '\t')) ++s;
    if ((size_t)(e - s) < 8 || strncmp(s, "include", 7) != 0 || (s[7] != ' ' && s[7] != '\t')) return 0;
    s += 7;
    while (s < e && (*s == ' ' || *s == '\t')) ++s;
    if (s == e || *s++ != '"') return 0;
    const char *name = s;
    while (s < e && *s != '"') ++s;
    if (s == e || s == name || (size_t)(s - name) >= out_size) return 0;
    memcpy(out, name, (size_t)(s - name));
    out[s - name] = '\0';
    for (++s; s < e; ++s)
        if (*s != ' ' && *s != '\t' && *s != '\r') return 0;
    return 1;
}

typedef struct expansion {
    char seen[MAX_INCLUDES][64];
    int nseen;
} expansion;

/* Append the text of `name` to out with its local includes expanded, each
 * file once (oclshade/runtime.py kernel_source does the same). */
static oclshade_status expand(oclshade *lib, const source_set *set, const char *name, expansion *ex, strbuf *out)
{
    for (int i = 0; i < ex->nseen; ++i)
        if (strcmp(ex->seen[i], name) == 0) return OCLSHADE_OK;
    if (ex->nseen == MAX_INCLUDES || strlen(name) >= sizeof ex->seen[0])
        return ocls_fail(lib, OCLSHADE_SOURCE_ERROR, 0, "kernel source \"%s\": too many includes or name too long", name);
    strcpy(ex->seen[ex->nseen++], name);
    char *text = NULL;
    oclshade_status st = load_source(lib, set, name, &text);
    if (st != OCLSHADE_OK) return st;
    for (const char *s = text; *s && st == OCLSHADE_OK;) {
        const char *e = strchr(s, '\n');
        const char *next = e ? e + 1 : s + strlen(s);
        if (e == NULL) e = next;
        char inc[64];
        if (include_line(s, e, inc, sizeof inc)) {
            st = expand(lib, set, inc, ex, out);
            if (out->len > 0 && out->p[out->len - 1] != '\n') sb_append(out, "\n", 1);
        } else {
            sb_append(out, s, (size_t)(next - s));
        }
        s = next;
    }
    free(text);
    if (st == OCLSHADE_OK && out->oom) st = ocls_fail(lib, OCLSHADE_OUT_OF_MEMORY, 0, "out of memory expanding %s", name);
    return st;
}

oclshade_status ocls_expanded_source(oclshade *lib, const source_set *set, const char *name, char **out)
{
    expansion ex;
    strbuf b = {NULL, 0, 0, 0};
    ex.nseen = 0;
    oclshade_status st = expand(lib, set, name, &ex, &b);
    if (st != OCLSHADE_OK) { free(b.p); return st; }
    *out = b.p;
    return OCLSHADE_OK;
}

const char *ocls_source(const oclshade *lib, const char *file)
{
    for (int i = 0; i < N_PROGRAM_FILES; ++i)
        if (strcmp(file, OCLS_PROGRAM_FILES[i]) == 0) return lib->sources[i];
    return NULL;
}

const char *oclshade_program_source(const oclshade *lib, const char *file)
{
    if (lib == NULL || lib->failed != OCLSHADE_OK || file == NULL) return NULL;
    return ocls_source(lib, file);
}
