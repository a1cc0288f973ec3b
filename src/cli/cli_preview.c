/* envlight preview: one PNG comparing the exact reference with every approximation. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const char preview_help[] =
    "Usage: envlight preview [FILE] -o OUT.png [options] [input options]\n"
    "One PNG: the lat-long map with the median cut regions outlined and the median cut and\n"
    "fitted lights marked, then spheres (rows: diffuse, glossy at two roughness values, mirror)\n"
    "lit by the exact reference and by each approximation in the rows it serves (median cut N\n"
    "and fit K + SH remainder: diffuse, glossy; SH order 2: diffuse; prefiltered maps: all),\n"
    "each with its error and seconds under it. The error is on what the picture shows:\n"
    "sqrt(mean((Ya - Yr)^2)) / mean(Yr) over the sphere's pixels, Y the luminance of the\n"
    "displayed (exposed, tone-mapped) colour. stderr repeats these and gives docs/design.md's\n"
    "diffuse error of each product.\n"
    "  -n N                 median cut lights (default 16)\n"
    "  -k K                 fitted lights, 1..32 (default 4)\n"
    "  --tonemap T          aces (default; Narkowicz 2015) or reinhard (x / (1 + x))\n"
    "  --exposure EV        display = tonemap(2^EV x radiance) (default: automatic,\n"
    "                       EV = log2(0.18 / log-average luminance of the map))\n"
    "  --diffuse D          lambert (default) or oren-nayar (sigma 0.3)\n"
    "  --specular S         ggx (default) or blinn-phong (exponent 2 / alpha^2 - 2)\n"
    "  --roughness A,B      the two glossy rows, 0.05..1 (default 0.25,0.5; alpha = r^2)\n"
    "  --sphere-size PX     48..512 (default 96); the PNG is 80 + 5 (PX + 24) + 8 wide\n"
    "  --reference-width W  the diffuse and glossy references sum over the map area-resampled\n"
    "                       to this width, 16..4096 (default 256)\n";

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
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v;
        long long n;
        double x;
        int r = cli_common_option("preview", argc, argv, &i, &c);
        if (r < 0)
            return CLI_USAGE;
        if (r > 0)
            continue;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            printf("%s\n%s", preview_help, cli_common_help);
            return CLI_OK;
        }
        if ((r = cli_value(argc, argv, &i, "-o", &v)) != 0) {
            if (r < 0)
                return cli_usage("preview", "-o needs a file name");
            out = v;
        } else if ((r = cli_value(argc, argv, &i, "-n", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 1, 4096, &n))
                return cli_usage("preview", "-n takes 1..4096");
            po.median_count = (int32_t)n;
        } else if ((r = cli_value(argc, argv, &i, "-k", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 1, 32, &n))
                return cli_usage("preview", "-k takes 1..32");
            po.fit_count = (int32_t)n;
        } else if ((r = cli_value(argc, argv, &i, "--tonemap", &v)) != 0) {
            if (r < 0 || (strcmp(v, "aces") && strcmp(v, "reinhard")))
                return cli_usage("preview", "--tonemap takes aces or reinhard");
            po.tonemap = strcmp(v, "aces") ? ENVL_PREVIEW_TONEMAP_REINHARD
                                           : ENVL_PREVIEW_TONEMAP_ACES;
        } else if ((r = cli_value(argc, argv, &i, "--exposure", &v)) != 0) {
            if (r < 0 || cli_parse_double(v, &x) || !(x >= -64 && x <= 64))
                return cli_usage("preview", "--exposure takes -64..64 (EV)");
            po.exposure_set = 1;
            po.exposure_ev = x;
        } else if ((r = cli_value(argc, argv, &i, "--diffuse", &v)) != 0) {
            if (r < 0 || (strcmp(v, "lambert") && strcmp(v, "oren-nayar")))
                return cli_usage("preview", "--diffuse takes lambert or oren-nayar");
            po.diffuse = strcmp(v, "lambert") ? ENVL_PREVIEW_DIFFUSE_OREN_NAYAR
                                              : ENVL_PREVIEW_DIFFUSE_LAMBERT;
        } else if ((r = cli_value(argc, argv, &i, "--specular", &v)) != 0) {
            if (r < 0 || (strcmp(v, "ggx") && strcmp(v, "blinn-phong")))
                return cli_usage("preview", "--specular takes ggx or blinn-phong");
            po.specular = strcmp(v, "ggx") ? ENVL_PREVIEW_SPECULAR_BLINN_PHONG
                                           : ENVL_PREVIEW_SPECULAR_GGX;
        } else if ((r = cli_value(argc, argv, &i, "--roughness", &v)) != 0) {
            if (r < 0 || parse_roughness(v, po.roughness))
                return cli_usage("preview", "--roughness takes A,B with each in 0.05..1");
        } else if ((r = cli_value(argc, argv, &i, "--sphere-size", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 48, 512, &n))
                return cli_usage("preview", "--sphere-size takes 48..512");
            po.sphere_size = (int32_t)n;
        } else if ((r = cli_value(argc, argv, &i, "--reference-width", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 16, 4096, &n) || n % 2)
                return cli_usage("preview", "--reference-width takes an even 16..4096");
            po.reference_width = (int32_t)n;
        } else if (a[0] == '-' && a[1]) {
            return cli_usage("preview", "unknown option '%s'", a);
        } else if (file) {
            return cli_usage("preview", "one FILE only");
        } else {
            file = a;
        }
    }
    if (!out || !strcmp(out, "-"))
        return cli_usage("preview", "-o OUT.png is required");
    envl_envmap *map;
    if (cli_load(file, &c, &map))
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
