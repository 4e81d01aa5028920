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

#define SOURCE_FILES "common.h, pyramid.cl, shadow.cl, terrain.cl, ssao.cl, compose.cl, sunshine.cl, horizon.cl, cubemap.h, envmap.cl, quadric.cl, terrain_ray.h, reflect.cl, mesh.cl and shadow_volume.cl"

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

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }

/* A match at p (p at the text's start or after a '\n') of the Python host's include pattern,
 * re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$', re.MULTILINE), with the same semantics:
 * the leading \s* may swallow blank lines before the directive, the trailing \s* whitespace up
 * to the last line end before the next text.  Returns the match's end (the name into out), or
 * NULL when the pattern does not match at p. */
static const char *include_at(const char *p, char *out, size_t out_size)
{
    const char *s = p;
    while (is_space(*s)) ++s;
    if (*s++ != '#') return NULL;
    while (is_space(*s)) ++s;
    if (strncmp(s, "include", 7) != 0 || !is_space(s[7])) return NULL;
    s += 7;
    while (is_space(*s)) ++s;
    if (*s++ != '"') return NULL;
    const char *name = s;
    while (*s && *s != '"') ++s;
    if (*s != '"' || s == name || (size_t)(s - name) >= out_size) return NULL;
    memcpy(out, name, (size_t)(s - name));
    out[s - name] = '\0';
    const char *after = ++s, *e = s;
    while (is_space(*e)) ++e;                       /* greedy \s* ... */
    while (e > after && *e != '\0' && *e != '\n') --e;   /* ... backed off until $ holds */
    if (*e != '\0' && *e != '\n') return NULL;
    return e;
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
    const char *copied = text;   /* text before it is in out */
    for (const char *s = text; *s && st == OCLSHADE_OK;) {
        char inc[64];
        const char *end = (s == text || s[-1] == '\n') ? include_at(s, inc, sizeof inc) : NULL;
        if (end != NULL) {
            sb_append(out, copied, (size_t)(s - copied));
            st = expand(lib, set, inc, ex, out);
            copied = s = end;
            continue;
        }
        const char *nl = strchr(s, '\n');
        s = nl ? nl + 1 : s + strlen(s);
    }
    sb_append(out, copied, strlen(copied));
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
