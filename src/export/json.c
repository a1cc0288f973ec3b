/* JSON writer (see json.h). */
#include "json.h"

#include <math.h>

/* Writes `s` as a JSON string literal (quotes included), always valid UTF-8 whatever the bytes
 * (file names are bytes): a byte sequence that is not well-formed UTF-8 becomes U+FFFD, one per
 * maximal subpart of an ill-formed sequence (Unicode 15, section 3.9, "U+FFFD Substitution of
 * Maximal Subparts"; what Python's bytes.decode('utf-8', 'replace') and WHATWG decoders do);
 * '"' and '\\' are escaped, and so are the control characters (C0, DEL, C1) and U+2028/U+2029
 * (line breaks to JavaScript), as \uXXXX. */
static void json_write_escaped(FILE *f, const char *s)
{
    fputc('"', f);
    const unsigned char *p = (const unsigned char *)s;
    while (*p) {
        unsigned c = *p;
        if (c < 0x80) {
            if (c == '"' || c == '\\')
                fprintf(f, "\\%c", c);
            else if (c == '\n')
                fputs("\\n", f);
            else if (c == '\r')
                fputs("\\r", f);
            else if (c == '\t')
                fputs("\\t", f);
            else if (c < 0x20 || c == 0x7f)
                fprintf(f, "\\u%04x", c);
            else
                fputc((int)c, f);
            p++;
            continue;
        }
        /* Table 3-7 of the Unicode standard: the lead byte fixes the length and the range of
         * the second byte; later bytes are 80..BF. */
        int n = c >= 0xc2 && c <= 0xdf   ? 2
                : c >= 0xe0 && c <= 0xef ? 3
                : c >= 0xf0 && c <= 0xf4 ? 4
                                         : 0; /* 80..C1, F5..FF never start a character */
        unsigned lo = c == 0xe0 ? 0xa0 : c == 0xf0 ? 0x90 : 0x80;
        unsigned hi = c == 0xed ? 0x9f : c == 0xf4 ? 0x8f : 0xbf;
        int k = 1; /* bytes of a well-formed prefix; the NUL ends any sequence */
        while (n && k < n && p[k] >= (k == 1 ? lo : 0x80) && p[k] <= (k == 1 ? hi : 0xbf))
            k++;
        if (!n || k < n) {
            fputs("\\ufffd", f); /* the maximal subpart p[0 .. k) is replaced */
            p += n ? k : 1;
            continue;
        }
        unsigned cp = n == 2 ? (c & 0x1f) << 6 | (p[1] & 0x3f)
                    : n == 3 ? (c & 0x0f) << 12 | (p[1] & 0x3fu) << 6 | (p[2] & 0x3f)
                             : (c & 0x07) << 18 | (p[1] & 0x3fu) << 12 | (p[2] & 0x3fu) << 6 |
                                   (p[3] & 0x3f);
        if (cp <= 0x9f || cp == 0x2028 || cp == 0x2029)
            fprintf(f, "\\u%04x", cp);
        else
            fwrite(p, 1, (size_t)n, f);
        p += n;
    }
    fputc('"', f);
}

static void member(json_writer *j, const char *key)
{
    if (j->count[j->depth]++)
        fputc(',', j->f);
    fputc('\n', j->f);
    for (int i = 0; i < j->depth; i++)
        fputs("  ", j->f);
    if (key) {
        json_write_escaped(j->f, key);
        fputs(": ", j->f);
    }
}

static void open_(json_writer *j, const char *key, char c)
{
    member(j, key);
    fputc(c, j->f);
    if (j->depth < 63)
        j->depth++;
    j->count[j->depth] = 0;
}

static void close_(json_writer *j, char c)
{
    int had = j->count[j->depth];
    j->depth--;
    if (had) {
        fputc('\n', j->f);
        for (int i = 0; i < j->depth; i++)
            fputs("  ", j->f);
    }
    fputc(c, j->f);
}

void json_begin(json_writer *j, FILE *f)
{
    j->f = f;
    j->depth = 0;
    j->count[0] = 0;
    fputc('{', f);
    j->depth = 1;
    j->count[1] = 0;
}

void json_end(json_writer *j)
{
    close_(j, '}');
    fputc('\n', j->f);
}

void json_object(json_writer *j, const char *key) { open_(j, key, '{'); }
void json_object_end(json_writer *j) { close_(j, '}'); }
void json_array(json_writer *j, const char *key) { open_(j, key, '['); }
void json_array_end(json_writer *j) { close_(j, ']'); }

void json_string(json_writer *j, const char *key, const char *value)
{
    member(j, key);
    json_write_escaped(j->f, value ? value : "");
}

static void number_text(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.9g", v);
    else
        fputs("null", f);
}

void json_number(json_writer *j, const char *key, double value)
{
    member(j, key);
    number_text(j->f, value);
}

void json_int(json_writer *j, const char *key, int64_t value)
{
    member(j, key);
    fprintf(j->f, "%lld", (long long)value);
}

void json_bool(json_writer *j, const char *key, int value)
{
    member(j, key);
    fputs(value ? "true" : "false", j->f);
}

/* Short arrays of numbers on one line: [r, g, b]. */
void json_numbers(json_writer *j, const char *key, const double *values, int n)
{
    member(j, key);
    fputc('[', j->f);
    for (int i = 0; i < n; i++) {
        if (i)
            fputs(", ", j->f);
        number_text(j->f, values[i]);
    }
    fputc(']', j->f);
}
