/* envlight preview: one PNG comparing the exact reference with every approximation. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const cli_command preview_command = {
    "preview",
    "Usage: envlight preview [FILE] -o OUT.png [options] [input options]\n"
    "One PNG: the lat-long map with the median cut regions outlined and the median cut and\n"
    "fitted lights marked, then spheres (rows: diffuse, glossy at two roughness values, mirror)\n"
    "lit by the exact reference and by each approximation in the rows it serves (median cut N\n"
    "and fit K + SH remainder: diffuse, glossy; SH order 2: diffuse; prefiltered maps: all),\n"
    "each with its error and seconds under it. The error is on what the picture shows:\n"
    "sqrt(mean((Ya - Yr)^2)) / mean(Yr) over the sphere's pixels, Y the luminance of the\n"
    "displayed (exposed, tone-mapped) colour. stderr repeats these and gives docs/design.md's\n"
    "diffuse error of each product.\n",
    NULL};

static int parse_roughness(const char *v, double r[2])
{
    char a[64];
    const char *comma = strchr(v, ',');
    if (!comma || (size_t)(comma - v) >= sizeof a)
        return -1;
    memcpy(a, v, (size_t)(comma - v));
    a[comma - v] = 0;
    if (cli_parse_double(a, &r[0]) || cli_parse_double(comma + 1, &r[1]))
        return -1;
    for (int k = 0; k < 2; k++)
        if (!(r[k] >= 0.05 && r[k] <= 1))
            return -1;
    return 0;
}

int cli_preview(int argc, char **argv)
{
    cli_common c = {0};
    const char *file = NULL, *out = NULL;
    envl_preview_options po = {0};
    const char *roughness = NULL;
    int npos;
    cli_option t[] = {
        CLI_OPTION("-o", "OUT.png", CLI_TEXT, .value = &out, .takes = "a file name",
                   .help = "the picture (PNG), written atomically"),
        CLI_OPTION("-n", "N", CLI_INT, .min = 1, .max = 4096, .value = &po.median_count,
                   .help = "median cut lights (default 16)"),
        CLI_OPTION("-k", "K", CLI_INT, .min = 1, .max = ENVL_FIT_MAX_LIGHTS,
                   .value = &po.fit_count, .help = "fitted lights, 1..32 (default 4)"),
        CLI_OPTION("--tonemap", "T", CLI_CHOICE, .value = &po.tonemap, .choices = "aces|reinhard",
                   .help = "aces (default; Narkowicz 2015) or reinhard (x / (1 + x))"),
        CLI_OPTION("--exposure", "EV", CLI_REAL, .min = -64, .max = 64, .value = &po.exposure_ev,
                   .help = "display = tonemap(2^EV x radiance) (default: automatic,\n"
                           "EV = log2(0.18 / log-average luminance of the map))"),
        CLI_OPTION("--diffuse", "D", CLI_CHOICE, .value = &po.diffuse,
                   .choices = "lambert|oren-nayar",
                   .help = "lambert (default) or oren-nayar (sigma 0.3)"),
        CLI_OPTION("--specular", "S", CLI_CHOICE, .value = &po.specular,
                   .choices = "ggx|blinn-phong",
                   .help = "ggx (default) or blinn-phong (exponent 2 / alpha^2 - 2)"),
        CLI_OPTION("--roughness", "A,B", CLI_TEXT, .value = &roughness,
                   .takes = "A,B with each in 0.05..1",
                   .help = "the two glossy rows, 0.05..1 (default 0.25,0.5; alpha = r^2)"),
        CLI_OPTION("--sphere-size", "PX", CLI_INT, .min = 48, .max = 512,
                   .value = &po.sphere_size,
                   .help = "48..512 (default 96); the PNG is 80 + 5 (PX + 24) + 8 wide"),
        CLI_OPTION("--reference-width", "W", CLI_INT, .min = 16, .max = 4096,
                   .value = &po.reference_width, .takes = "an even 16..4096",
                   .help = "the diffuse and glossy references sum over the map area-resampled\n"
                           "to this width, 16..4096 (default 256)"),
    };
    int parsed = cli_parse(&preview_command, t, CLI_COUNT(t), &c, argc, argv, &file, 1, &npos);
    if (parsed)
        return parsed == CLI_HELP ? CLI_OK : parsed;
    /* the table's order is the library's: ENVL_PREVIEW_TONEMAP_ACES 0, _REINHARD 1, ... */
    po.exposure_set = cli_seen(t, CLI_COUNT(t), "--exposure") != NULL;
    if (roughness && parse_roughness(roughness, po.roughness))
        return cli_usage("preview", "--roughness takes A,B with each in 0.05..1, not '%s'",
                         roughness);
    if (po.reference_width % 2)
        return cli_usage("preview", "--reference-width takes an even 16..4096, not '%d'",
                         (int)po.reference_width);
    if (!out || !strcmp(out, "-"))
        return cli_usage("preview", "-o OUT.png is required");
    envl_envmap *map;
    if (cli_outputs_ok(&file, 1, &out, 1) || cli_load(file, &c, &map))
        return CLI_FAIL;
    po.title = file && strcmp(file, "-") ? file : "built-in sky";
    int32_t w = 0, h = 0;
    envl_result rc = envl_preview_write(map, &po, out, c.quiet ? NULL : stderr, &w, &h);
    int status = rc ? cli_fail() : CLI_OK;
    if (!rc && !c.quiet)
        fprintf(stderr, "envlight preview: wrote %s (%d x %d)\n", out, (int)w, (int)h);
    envl_envmap_free(map);
    return status;
}
