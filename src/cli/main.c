/* `envlight`: the command table and main(). Each command lives in its own cli_*.c (the bench
 * harness in src/lab/); the options they share are in cli.c. */
#include "cli.h"

#include <signal.h>
#include <stdio.h>
#include <string.h>

typedef struct command {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *usage;   /* what follows the name in the help's list */
    const char *summary;
} command;

/* One table: main() dispatches through it and the help is written from it. */
static const command commands[] = {
    {"info", cli_info, "FILE [--json]", "size, layout, channels, statistics, power, brightest direction"},
    {"convert", cli_convert, "IN OUT", "convert between .hdr/.exr/.pfm and into the canonical lat-long"},
    {"lights", cli_lights, "[FILE]", "directional lights: median cut, variance cut, fit + SH remainder"},
    {"sh", cli_sh, "[FILE]", "spherical harmonics of any order, windowed, artist forms"},
    {"pov", cli_pov, "[FILE] -o OUT.inc", "POV-Ray include: light_sources, ambient, sky"},
    {"gltf", cli_gltf, "[FILE] -o OUT.glb", "glTF 2.0: the suns as lights + the rest as an IBL"},
    {"prefilter", cli_prefilter, "[FILE] -o DIR", "irradiance map, GGX specular chain, RGBM atlas"},
    {"brdf-lut", cli_brdf_lut, "-o FILE", "split-sum GGX BRDF table"},
    {"preview", cli_preview, "[FILE] -o OUT.png", "reference vs approximations on spheres, side by side"},
    {"bench", cli_bench, "[FILES...]", "accuracy against time, as Markdown tables"},
};
enum { COMMANDS = sizeof commands / sizeof commands[0] };

static void help(FILE *f)
{
    fputs("envlight: HDR environment images into lights, spherical harmonics and prefiltered maps.\n"
          "\n"
          "Usage: envlight COMMAND [options]   ('envlight COMMAND --help' for each)\n"
          "\n"
          "Commands:\n", f);
    for (int i = 0; i < COMMANDS; i++) {
        char head[64];
        snprintf(head, sizeof head, "%s %s", commands[i].name, commands[i].usage);
        fprintf(f, "  %-26s  %s\n", head, commands[i].summary);
    }
    fprintf(f, "  %-26s  %s\n", "version", "library version");
    fputs("\n"
          "FILE '-' (or no FILE where it makes sense) is the built-in procedural sky.\n"
          "Exit status: 0 success, 1 bad input or failure, 2 bad usage.\n", f);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        help(stderr);
        return CLI_USAGE;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help")) {
        help(stdout);
        return CLI_OK;
    }
    if (!strcmp(cmd, "version") || !strcmp(cmd, "--version")) {
        printf("envlight %s (ABI %d)\n", envl_version_string(), (int)envl_abi_version());
        return CLI_OK;
    }
    for (int i = 0; i < COMMANDS; i++)
        if (!strcmp(cmd, commands[i].name)) {
            int rc = commands[i].run(argc - 1, argv + 1);
            int sig = cli_interrupted();
            if (sig && rc != CLI_OK) { /* cancelled (nothing written): end as the signal asked */
                fprintf(stderr, "envlight: %s: %s stopped at its next step; no output file was "
                        "written or changed\n", sig == SIGINT ? "interrupted" : "terminated", cmd);
                signal(sig, SIG_DFL);
                raise(sig);
            }
            return rc;
        }
    fprintf(stderr, "envlight: unknown command '%s'\n\n", cmd);
    help(stderr);
    return CLI_USAGE;
}
