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
    cli_common c = {0};
    for (int i = 1; i < argc; i++) {
        const char *v;
        if (cli_common_option("fuzz", argc, argv, &i, &c) == 0 &&
            cli_value(argc, argv, &i, "-n", &v) > 0) {
            long long n;
            cli_parse_int(v, 1, 1 << 24, &n);
        }
    }
    free(buf);
    return 0;
}
