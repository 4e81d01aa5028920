/* specialize.c — paper 002's @IF meta-language resolved for a condition vector: a port of
 * oclshade/specialize.py specialize() (without keep_line_numbers).
 *
 *   @IF cond1 [cond2 ...];   taken if ANY listed condition holds; "!cond" negates one
 *   [@ELSE;]
 *   @ENDIF;
 *
 * A directive is a line whose first non-blank character is '@'.  Lines end at '\n' (a "\r\n"
 * line keeps its '\r'; Python's splitlines also splits at a lone '\r' and a few control
 * characters, which kernel sources do not hold).  Malformed input gives the Python host's
 * messages, "line N: ...". */
#include "internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_DEPTH 64

static int is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }
static int is_first(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_'; }
static int is_next(char c) { return is_first(c) || (c >= '0' && c <= '9'); }

/* [s, e) is a NAME ([A-Za-z_][A-Za-z0-9_]*) */
static int is_name(const char *s, const char *e)
{
    if (s == e || !is_first(*s)) return 0;
    for (++s; s < e; ++s)
        if (!is_next(*s)) return 0;
    return 1;
}

/* the word [s, e) is one of the condition vector's names */
static int in_vector(const char *vector, const char *s, const char *e)
{
    const size_t n = (size_t)(e - s);
    for (const char *p = vector; *p;) {
        while (*p && is_blank(*p)) ++p;
        const char *q = p;
        while (*q && !is_blank(*q)) ++q;
        if ((size_t)(q - p) == n && n > 0 && strncmp(p, s, n) == 0) return 1;
        p = q;
    }
    return 0;
}

typedef struct block { int line, parent_on, taken, in_else; } block;

static int block_on(const block *b) { return b->parent_on && (b->taken != b->in_else); }

/* Appends [s, e) to out (when out has room; *len counts every byte). */
static void emit(char *out, size_t size, size_t *len, const char *s, size_t n)
{
    if (out != NULL && *len < size) memcpy(out + *len, s, *len + n <= size ? n : size - *len);
    *len += n;
}

int ocls_specialize(const char *source, const char *conditions, char *out, size_t size, size_t *needed,
                    char *error, size_t error_size)
{
    char dummy[1];
    if (error == NULL || error_size == 0) { error = dummy; error_size = sizeof dummy; }
    error[0] = '\0';
    /* the condition vector: names separated by blanks */
    for (const char *p = conditions; *p;) {
        while (*p && is_blank(*p)) ++p;
        const char *q = p;
        while (*q && !is_blank(*q)) ++q;
        if (q > p && !is_name(p, q)) {
            snprintf(error, error_size, "conditions must be names like 'BUMP SPECULAR' (letters, digits, _); got '%.*s'",
                     (int)(q - p), p);
            return 0;
        }
        p = q;
    }
    block stack[MAX_DEPTH];
    int depth = 0, line = 0;
    size_t len = 0;
    for (const char *s = source; *s;) {
        const char *nl = strchr(s, '\n');
        const char *next = nl ? nl + 1 : s + strlen(s);
        ++line;
        const int on = depth ? block_on(&stack[depth - 1]) : 1;
        const char *b = s;
        while (b < next && is_blank(*b)) ++b;
        if (b == next || *b != '@') {
            if (on) emit(out, size, &len, s, (size_t)(next - s));
            s = next;
            continue;
        }
        /* a directive: body = the stripped line after '@' */
        const char *e = next;
        while (e > b && is_blank(e[-1])) --e;
        const char *body = b + 1, *semi = memchr(body, ';', (size_t)(e - body));
        const int shown = (int)(e - b);
        if (semi == NULL) {
            snprintf(error, error_size, "line %d: directive '%.*s' must end with ';'", line, shown, b);
            return 0;
        }
        const char *rest = semi + 1;
        while (rest < e && is_blank(*rest)) ++rest;
        if (rest < e) {
            snprintf(error, error_size, "line %d: unexpected text '%.*s' after ';' in '%.*s'", line, (int)(e - rest), rest,
                     shown, b);
            return 0;
        }
        const char *w = body;
        while (w < semi && is_blank(*w)) ++w;
        const char *we = w;
        while (we < semi && !is_blank(*we)) ++we;
        if (w == we) {
            snprintf(error, error_size, "line %d: empty directive '@;'", line);
            return 0;
        }
        const size_t kw = (size_t)(we - w);
        const char *args = we;
        while (args < semi && is_blank(*args)) ++args;
        const char *args_end = semi;
        while (args_end > args && is_blank(args_end[-1])) --args_end;
        if (kw == 2 && strncmp(w, "IF", 2) == 0) {
            if (args == args_end) {
                snprintf(error, error_size, "line %d: @IF needs at least one condition, e.g. '@IF BUMP !SPOT;'", line);
                return 0;
            }
            int taken = 0;
            for (const char *a = args; a < args_end;) {
                const char *ae = a;
                while (ae < args_end && !is_blank(*ae)) ++ae;
                const int neg = *a == '!';
                if (!is_name(a + neg, ae)) {
                    snprintf(error, error_size, "line %d: bad condition '%.*s' in @IF: expected NAME or !NAME", line,
                             (int)(ae - a), a);
                    return 0;
                }
                taken |= in_vector(conditions, a + neg, ae) != neg;
                a = ae;
                while (a < args_end && is_blank(*a)) ++a;
            }
            if (depth == MAX_DEPTH) {
                snprintf(error, error_size, "line %d: @IF blocks nested deeper than %d", line, MAX_DEPTH);
                return 0;
            }
            stack[depth].line = line;
            stack[depth].parent_on = on;
            stack[depth].taken = taken;
            stack[depth].in_else = 0;
            ++depth;
        } else if ((kw == 4 && strncmp(w, "ELSE", 4) == 0) || (kw == 5 && strncmp(w, "ENDIF", 5) == 0)) {
            if (args < args_end) {
                snprintf(error, error_size, "line %d: @%.*s takes no condition, got '%.*s'", line, (int)kw, w,
                         (int)(args_end - args), args);
                return 0;
            }
            if (depth == 0) {
                snprintf(error, error_size, "line %d: @%.*s; without a matching @IF", line, (int)kw, w);
                return 0;
            }
            if (kw == 4) {
                if (stack[depth - 1].in_else) {
                    snprintf(error, error_size, "line %d: second @ELSE; for the @IF on line %d", line, stack[depth - 1].line);
                    return 0;
                }
                stack[depth - 1].in_else = 1;
            } else {
                --depth;
            }
        } else {
            snprintf(error, error_size, "line %d: unknown directive '@%.*s'; expected @IF, @ELSE or @ENDIF", line,
                     (int)kw, w);
            return 0;
        }
        s = next;
    }
    if (depth) {
        snprintf(error, error_size, "line %d: @IF not closed by @ENDIF; before the end of the source (%d open)",
                 stack[depth - 1].line, depth);
        return 0;
    }
    emit(out, size, &len, "", 1);   /* the NUL */
    if (out != NULL && size > 0) out[len <= size ? len - 1 : size - 1] = '\0';
    *needed = len;
    return 1;
}

oclshade_status oclshade_specialize(const char *source, const char *conditions, char *out, size_t size,
                                    size_t *needed, char *error, size_t error_size)
{
    if (error != NULL && error_size > 0) error[0] = '\0';
    if (source == NULL || conditions == NULL || needed == NULL) {
        if (error != NULL && error_size > 0)
            snprintf(error, error_size, "source, conditions and needed must not be NULL");
        return OCLSHADE_INVALID_ARGUMENT;
    }
    *needed = 0;
    return ocls_specialize(source, conditions, out, size, needed, error, error_size) ? OCLSHADE_OK
                                                                                      : OCLSHADE_SOURCE_ERROR;
}
