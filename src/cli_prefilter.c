/* envlight prefilter, envlight brdf-lut. (being written) */
#include "cli.h"

int cli_prefilter(int argc, char **argv)
{
    cli_error("prefilter: not written yet");
    return CLI_FAIL;
}

int cli_brdf_lut(int argc, char **argv)
{
    cli_error("brdf-lut: not written yet");
    return CLI_FAIL;
}
