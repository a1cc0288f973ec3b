/* libFuzzer target for the command line's option parsing: the input, split at NUL bytes, is an
 * argument vector handed to the shared option parser (no files are read or written). */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > 4096)
        return 0;
    char *buf = malloc(size + 1);
    if (!buf)
        return 0;
    memcpy(buf, data, size);
    buf[size] = '\0';
    char *argv[64];
    int argc = 0;
    argv[argc++] = "fuzz";
    for (size_t i = 0; i <= size && argc < 63;) {
        argv[argc++] = buf + i;
        i += strlen(buf + i) + 1;
    }
    argv[argc] = NULL;
    /* a table with every kind of option, and the input options */
    static const cli_command cmd = {"fuzz", "Usage: fuzz\n", NULL};
    cli_common c = {0};
    int n = 0, flag = 0, choice = 0, bits = 0;
    int64_t big = 0;
    double x = 0;
    const char *text = NULL, *pos[4];
    cli_option t[] = {
        CLI_OPTION("-n|--count", "N", CLI_INT, .min = 1, .max = 1 << 24, .value = &n, .help = ""),
        CLI_OPTION("--flag", NULL, CLI_FLAG, .max = 2, .value = &flag, .help = ""),
        CLI_OPTION("--big", "N", CLI_INT64, .min = 1, .max = 9.2e18, .value = &big, .help = ""),
        CLI_OPTION("--x", "X", CLI_REAL, .min = -1, .max = 1, .value = &x, .help = "a\nb"),
        CLI_OPTION("--choice", "C", CLI_CHOICE, .value = &choice, .choices = "a|bb|c",
                   .help = ""),
        CLI_OPTION("--method", "M", CLI_CHOICE, .value = &choice, .choices = "fit|median",
                   .lookup = envl_method_from_name, .help = ""),
        CLI_OPTION("--bits", "B", CLI_CHOICE, .value = &bits, .bits = 1, .choices = "a|b|c",
                   .help = ""),
        CLI_OPTION("--text", "T", CLI_TEXT, .value = &text, .help = ""),
    };
    int npos;
    /* usage errors go to stderr; the parse must never read or write out of bounds */
    cli_parse(&cmd, t, CLI_COUNT(t), &c, argc, argv, pos, 4, &npos);
    free(buf);
    return 0;
}
