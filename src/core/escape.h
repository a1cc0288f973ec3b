/* Control characters in a message (a file name's, a header's text) shown as \xHH, so that no
 * escape sequence reaches a terminal. Header-only: the library's messages (error.c) and the
 * command line's own (cli.c, linked to the shared library, whose internals are hidden) both
 * use it. */
#ifndef ENVL_ESCAPE_H
#define ENVL_ESCAPE_H

#include <stdio.h>
#include <string.h>

/* In place within `cap` bytes (messages of up to 2048 bytes). */
static inline void escape_controls(char *s, size_t cap)
{
    size_t n = strlen(s), controls = 0;
    for (size_t i = 0; i < n; i++)
        controls += (unsigned char)s[i] < 0x20 || s[i] == 0x7f;
    if (!controls || !cap)
        return;
    char tmp[8192]; /* each byte at most 4; cut to cap below */
    size_t o = 0;
    for (size_t i = 0; i < n && o + 5 < sizeof tmp; i++) {
        unsigned char c = (unsigned char)s[i];
        if (c < 0x20 || c == 0x7f)
            o += (size_t)snprintf(tmp + o, 5, "\\x%02x", c);
        else
            tmp[o++] = (char)c;
    }
    size_t m = o < cap - 1 ? o : cap - 1; /* cut to fit */
    memcpy(s, tmp, m);
    s[m] = '\0';
}

#endif
