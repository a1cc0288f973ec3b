/* envlight pov: POV-Ray include files. (being written) */
#include "cli.h"

int cli_pov(int argc, char **argv)
{
    cli_error("pov: not written yet");
    return CLI_FAIL;
}
