/* A small JSON writer for the CLI: keys in insertion order, numbers with 9 significant
 * digits, non-finite numbers as null, strings escaped. */
#ifndef ENVL_JSON_H
#define ENVL_JSON_H

#include <stdint.h>
#include <stdio.h>

typedef struct json_writer {
    FILE *f;
    int depth;
    int count[64]; /* members written at each depth */
} json_writer;

void json_begin(json_writer *j, FILE *f);           /* opens the top-level object */
void json_end(json_writer *j);                       /* closes it, newline */
void json_object(json_writer *j, const char *key);   /* key NULL inside arrays */
void json_object_end(json_writer *j);
void json_array(json_writer *j, const char *key);
void json_array_end(json_writer *j);
void json_string(json_writer *j, const char *key, const char *value);
void json_number(json_writer *j, const char *key, double value);
void json_int(json_writer *j, const char *key, int64_t value);
void json_bool(json_writer *j, const char *key, int value);
void json_numbers(json_writer *j, const char *key, const double *values, int n);
/* Writes `s` as a JSON string literal (quotes included), always valid UTF-8 whatever the bytes
 * (file names are bytes): a byte sequence that is not well-formed UTF-8 becomes U+FFFD, one per
 * maximal subpart of an ill-formed sequence (Unicode 15, section 3.9, "U+FFFD Substitution of
 * Maximal Subparts"; what Python's bytes.decode('utf-8', 'replace') and WHATWG decoders do);
 * '"' and '\\' are escaped, and so are the control characters (C0, DEL, C1) and U+2028/U+2029
 * (line breaks to JavaScript), as \uXXXX. Defined here, header-only, so that the library's
 * sidecar writer (prefilter.c) and the command line's JSON writer (json.c) share one copy. */
static inline void json_write_escaped(FILE *f, const char *s)
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

#endif
