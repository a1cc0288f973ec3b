/* envlight prefilter: irradiance map, GGX specular chain, RGBM atlas; envlight brdf-lut. */
#include "cli.h"
#include "clock.h"
#include "json.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char prefilter_help[] =
    "Usage: envlight prefilter [FILE] -o DIR [--irradiance] [--specular] [--levels K]\n"
    "                          [--size S] [--samples M] [--format exr|hdr|pfm|rgbm-png]\n"
    "                          [--layout latlong|cube|cross|atlas] [--roughness LIST]\n"
    "                          [--json] [input options]\n"
    "Prefiltered maps into DIR (created if missing), with a JSON sidecar DIR/prefilter.json\n"
    "giving the conventions (frame, roughness mapping, RGBM range, layout) and every file.\n"
    "  --irradiance       the diffuse irradiance map (irradiance.EXT)\n"
    "  --specular         the GGX specular chain (specular_NN.EXT); default: both\n"
    "  --levels K         levels of the chain, roughness k / (K - 1), alpha = roughness^2\n"
    "                     (default 6)\n"
    "  --roughness LIST   comma-separated roughness values in [0, 1]: only these levels\n"
    "                     (instead of the chain)\n"
    "  --size S           lat-long width of the roughness-0 level (default 512), or the cube\n"
    "                     face size for --layout cube|cross (default 256); level k is S >> k\n"
    "  --min-size S       no level narrower than S (lat-long width; default 64)\n"
    "  --samples M        GGX samples per texel at the base width S (default 64; a level w\n"
    "                     wide: M (S / w)^2, at most 8 M; filtered importance sampling)\n"
    "  --unfiltered       plain GGX importance sampling of the full map (the baseline)\n"
    "  --sun-lights       the sun (pixels above 50x the mean luminance) as lights in the\n"
    "                     sidecar, left out of the irradiance map and the glossy levels, for\n"
    "                     the renderer to add analytically; errors are measured with them\n"
    "  --irradiance-method resampled|sh|exact   (default resampled: exact sum over the map\n"
    "                     area-averaged to 256 x 128; sh: SH of --irradiance-order with\n"
    "                     the auto window (never negative); exact: every pixel, slow)\n"
    "  --irradiance-order L   SH order for --irradiance-method sh (default 2)\n"
    "  --irradiance-size S    lat-long width (default 64; cube face 32)\n"
    "  --format F         exr (float, default), hdr, pfm, rgbm-png (RGBA8, rgb = 6 rgb.a)\n"
    "  --layout L         latlong (default), cube (6 files per map), cross (vertical), atlas\n"
    "                     (the levels stacked in one image; needs the 6-level chain or a list;\n"
    "                     with rgbm-png also writes brdf_lut.png, sRGB)\n"
    "  --brdf             also write the BRDF table (brdf_lut.EXT)\n"
    "  --no-error         skip the error measures (the glossy one sums every pixel per\n"
    "                     direction and can take seconds)\n"
    "  --json             print the sidecar to stdout instead of the summary\n";

static const char brdf_help[] =
    "Usage: envlight brdf-lut -o FILE [--size S] [--samples N] [--multiscatter] [--json]\n"
    "Split-sum GGX BRDF table (height-correlated Smith), integrated in double. Column i:\n"
    "NoV = (i + 0.5) / S; row j from the top: roughness = (j + 0.5) / S (alpha = roughness^2).\n"
    "Channels: R = A (scale), G = B (bias), specular = F0 A + B; --multiscatter: R = B,\n"
    "G = A + B, specular = mix(R, G, F0) * (1 + F0 (1 / G - 1)) (Turquin 2019 compensation).\n"
    "FILE .exr/.pfm/.hdr: float R, G, blue 0; .png: 8-bit sRGB. A sidecar FILE.json says so.\n"
    "  --size S       table size (default 128)\n"
    "  --samples N    GGX samples per texel (default 4096)\n";

static int parse_list(const char *v, double **out, int32_t *n)
{
    int32_t cap = 1;
    for (const char *s = v; *s; s++)
        cap += *s == ',';
    double *r = malloc(sizeof(double) * cap);
    if (!r)
        return -1;
    char *copy = strdup(v), *save = NULL;
    int32_t k = 0;
    for (char *t = strtok_r(copy, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        double d;
        if (cli_parse_double(t, &d) || !(d >= 0 && d <= 1)) {
            free(copy);
            free(r);
            return -1;
        }
        r[k++] = d;
    }
    free(copy);
    if (!k) {
        free(r);
        return -1;
    }
    *out = r;
    *n = k;
    return 0;
}

static int print_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        cli_error("%s: %s", path, strerror(errno));
        return CLI_FAIL;
    }
    char buf[65536];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        fwrite(buf, 1, n, stdout);
    fclose(f);
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}

int cli_prefilter(int argc, char **argv)
{
    cli_common c = {0};
    const char *file = NULL, *dir = NULL;
    envl_request q = {0};
    envl_export_options eo = {0};
    int want_irr = 0, want_spec = 0, json = 0, measure = 1, brdf = 0;
    long long size = 0, irr_size = 0, min_size = 0;
    double *list = NULL;
    int32_t nlist = 0;
    int rc = CLI_OK;
#define USAGE(...) (free(list), cli_usage("prefilter", __VA_ARGS__))
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v;
        long long n;
        int r = cli_common_option("prefilter", argc, argv, &i, &c);
        if (r < 0)
            return free(list), CLI_USAGE;
        if (r > 0)
            continue;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            printf("%s\n%s", prefilter_help, cli_common_help);
            free(list);
            return CLI_OK;
        }
        if ((r = cli_value(argc, argv, &i, "-o", &v)) != 0) {
            if (r < 0)
                return USAGE("-o needs a directory");
            dir = v;
        } else if ((r = cli_value(argc, argv, &i, "--levels", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 1, 16, &n))
                return USAGE("--levels takes 1..16");
            q.prefilter.levels = (int32_t)n;
        } else if ((r = cli_value(argc, argv, &i, "--size", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 2, 16384, &size))
                return USAGE("--size takes 2..16384");
        } else if ((r = cli_value(argc, argv, &i, "--min-size", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 2, 16384, &min_size))
                return USAGE("--min-size takes 2..16384");
        } else if ((r = cli_value(argc, argv, &i, "--samples", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 1, 1 << 20, &n))
                return USAGE("--samples takes 1..1048576");
            q.prefilter.samples = (int32_t)n;
        } else if ((r = cli_value(argc, argv, &i, "--format", &v)) != 0) {
            if (r < 0 || (strcmp(v, "exr") && strcmp(v, "hdr") && strcmp(v, "pfm") &&
                          strcmp(v, "rgbm-png")))
                return USAGE("--format takes exr, hdr, pfm or rgbm-png");
            eo.format = v;
        } else if ((r = cli_value(argc, argv, &i, "--layout", &v)) != 0) {
            if (r < 0 || (eo.layout = envl_export_layout_from_name(v)) < 0)
                return USAGE("--layout takes latlong, cube, cross or atlas");
        } else if ((r = cli_value(argc, argv, &i, "--roughness", &v)) != 0) {
            free(list);
            list = NULL;
            if (r < 0 || parse_list(v, &list, &nlist))
                return USAGE("--roughness takes a comma-separated list of values in [0, 1]");
        } else if ((r = cli_value(argc, argv, &i, "--irradiance-method", &v)) != 0) {
            if (r < 0 || (q.prefilter.irradiance_method = envl_irradiance_method_from_name(v)) < 0)
                return USAGE("--irradiance-method takes resampled, sh or exact");
        } else if ((r = cli_value(argc, argv, &i, "--irradiance-order", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 0, 32, &n))
                return USAGE("--irradiance-order takes 0..32");
            q.prefilter.irradiance_order = n == 0 ? ENVL_ORDER_0 : (int32_t)n;
        } else if ((r = cli_value(argc, argv, &i, "--irradiance-size", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 2, 16384, &irr_size))
                return USAGE("--irradiance-size takes 2..16384");
        } else if (!strcmp(a, "--irradiance")) {
            want_irr = 1;
        } else if (!strcmp(a, "--specular")) {
            want_spec = 1;
        } else if (!strcmp(a, "--unfiltered")) {
            q.prefilter.unfiltered = 1;
        } else if (!strcmp(a, "--sun-lights")) {
            q.prefilter.sun_lights = 1;
        } else if (!strcmp(a, "--brdf")) {
            brdf = 1;
        } else if (!strcmp(a, "--no-error")) {
            measure = 0;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else if (a[0] == '-' && a[1]) {
            return USAGE("unknown option '%s'", a);
        } else if (file) {
            return USAGE("one FILE only");
        } else {
            file = a;
        }
    }
    if (!dir)
        return USAGE("-o DIR is required");
    if (nlist)
        want_spec = 1;
    if (!want_irr && !want_spec)
        want_irr = want_spec = 1;
    int cube = eo.layout == ENVL_EXPORT_CUBE || eo.layout == ENVL_EXPORT_CROSS;
    if (eo.layout == ENVL_EXPORT_ATLAS && !want_spec)
        return USAGE("--layout atlas needs specular levels");
    /* Cube faces of size S come from lat-long maps 4 S wide. */
    q.prefilter.width = (int32_t)(size ? (cube ? 4 * size : size) : (cube ? 1024 : 512));
    if (min_size)
        q.prefilter.min_width = (int32_t)min_size;
    q.prefilter.irradiance_width = (int32_t)(irr_size ? (cube ? 4 * irr_size : irr_size)
                                                      : (cube ? 128 : 64));
    q.prefilter.threads = c.load.threads;
    q.irradiance_map = want_irr;
    if (want_spec) {
        if (nlist) {
            q.n_roughness = nlist;
            q.roughness = list;
        } else {
            q.specular_chain = 1;
        }
    }
    q.brdf_lut = brdf || (eo.format && !strcmp(eo.format, "rgbm-png") &&
                          eo.layout == ENVL_EXPORT_ATLAS);
    q.brdf.threads = c.load.threads;
    q.measure = measure;

    envl_envmap *map;
    if (cli_load(file, &c, &map)) {
        free(list);
        return CLI_FAIL;
    }
    /* the folder only once the products are computed: a bad input, or products that
     * overflow, leave nothing behind */
    envl_products *p = NULL;
    if (envl_compute(map, &q, &p)) {
        rc = cli_fail();
        goto done;
    }
    if (mkdir(dir, 0777) != 0 && errno != EEXIST) {
        cli_error("%s: cannot create the directory: %s", dir, strerror(errno));
        rc = CLI_FAIL;
        goto done;
    }
    if (envl_products_export(p, dir, &eo)) {
        rc = cli_fail();
        goto done;
    }
    if (json) {
        char path[4096];
        snprintf(path, sizeof path, "%s/prefilter.json", dir);
        rc = print_file(path);
        goto done;
    }
    envl_info info;
    envl_envmap_info(map, &info);
    envl_products_summary s;
    envl_products_get_summary(p, &s);
    printf("%s: %d x %d -> %s (%s, %s), %.3f s", info.file, (int)info.width, (int)info.height,
           dir, eo.format ? eo.format : "exr", envl_export_layout_name(eo.layout), s.seconds);
    if (s.specular_levels)
        printf("; mip pyramid %.3f s", s.seconds_pyramid);
    printf("\n");
    envl_irradiance_map irr;
    if (envl_products_irradiance(p, &irr) == ENVL_OK) {
        printf("irradiance   %-9s %5d x %-5d", envl_irradiance_method_name(irr.method),
               (int)irr.width, (int)irr.height);
        if (irr.diffuse_error >= 0)
            printf("  diffuse error %.3f %%", 100 * irr.diffuse_error);
        printf("  %.3f s\n", irr.seconds);
    }
    for (int32_t i = 0; i < envl_products_level_count(p); i++) {
        envl_level l;
        envl_products_level(p, i, &l);
        printf("specular_%02d  r %.3f alpha %.4f %5d x %-5d samples %4d%s", (int)i, l.roughness,
               l.alpha, (int)l.width, (int)l.height, (int)l.samples,
               l.samples ? (l.filtered ? " filtered" : " plain") : " (resampled)");
        if (l.glossy_error >= 0)
            printf("  glossy error %.3f %%", 100 * l.glossy_error);
        printf("  %.3f s\n", l.seconds);
    }
    int32_t nsun;
    const envl_light *sun = envl_products_sun_lights(p, &nsun);
    for (int32_t i = 0; i < nsun; i++)
        printf("sun_light_%02d direction %.4f %.4f %.4f  rgb %.5g %.5g %.5g  angle %.3f deg\n",
               (int)i, sun[i].direction[0], sun[i].direction[1], sun[i].direction[2],
               sun[i].rgb[0], sun[i].rgb[1], sun[i].rgb[2], sun[i].angle * 180 / ENVL_PI);
    int32_t bs;
    if (envl_products_brdf(p, &bs, NULL))
        printf("brdf_lut     %d x %d  %.3f s\n", (int)bs, (int)bs, s.seconds_brdf);
    if (fflush(stdout))
        rc = CLI_FAIL;
done:
    envl_products_free(p);
    envl_envmap_free(map);
    free(list);
    return rc;
#undef USAGE
}

static const char *ext_of(const char *path)
{
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    return dot && (!slash || dot > slash) ? dot + 1 : "";
}

int cli_brdf_lut(int argc, char **argv)
{
    const char *out = NULL;
    envl_brdf_options bo = {0};
    int json = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v;
        long long n;
        int r;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(brdf_help, stdout);
            return CLI_OK;
        }
        if ((r = cli_value(argc, argv, &i, "-o", &v)) != 0) {
            if (r < 0)
                return cli_usage("brdf-lut", "-o needs a file name");
            out = v;
        } else if ((r = cli_value(argc, argv, &i, "--size", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 1, 4096, &n))
                return cli_usage("brdf-lut", "--size takes 1..4096");
            bo.size = (int32_t)n;
        } else if ((r = cli_value(argc, argv, &i, "--samples", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 1, 1 << 24, &n))
                return cli_usage("brdf-lut", "--samples takes 1..16777216");
            bo.samples = (int32_t)n;
        } else if ((r = cli_value(argc, argv, &i, "--threads", &v)) != 0) {
            if (r < 0 || cli_parse_int(v, 1, ENVL_MAX_THREADS, &n))
                return cli_usage("brdf-lut", "--threads takes 1..%d", ENVL_MAX_THREADS);
            bo.threads = (int32_t)n;
        } else if (!strcmp(a, "--multiscatter")) {
            bo.multiscatter = 1;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else {
            return cli_usage("brdf-lut", "unknown argument '%s'", a);
        }
    }
    if (!out)
        return cli_usage("brdf-lut", "-o FILE is required");
    const char *ext = ext_of(out);
    int png = !strcasecmp(ext, "png");
    if (!png && strcasecmp(ext, "exr") && strcasecmp(ext, "pfm") && strcasecmp(ext, "hdr"))
        return cli_usage("brdf-lut", "FILE must end in .exr, .pfm, .hdr or .png");
    double t0 = envl__seconds();
    float *rg;
    int32_t s;
    if (envl_brdf_lut(&bo, &rg, &s))
        return cli_fail();
    double seconds = envl__seconds() - t0;
    int32_t samples = bo.samples ? bo.samples : ENVL_BRDF_DEFAULT_SAMPLES;
    /* Integration error estimate: a grid of texels again with 4x the samples. */
    double err = 0;
    int32_t step = s / 8 > 0 ? s / 8 : 1;
    for (int32_t j = step / 2; j < s; j += step)
        for (int32_t i = step / 2; i < s; i += step) {
            double ab[2];
            envl_brdf_eval((i + 0.5) / s, (j + 0.5) / s,
                           samples <= (1 << 22) ? 4 * samples : samples, ab);
            double x = bo.multiscatter ? ab[1] : ab[0], y = bo.multiscatter ? ab[0] + ab[1] : ab[1];
            const float *p = rg + 2 * ((size_t)j * s + i);
            err = fmax(err, fmax(fabs(p[0] - x), fabs(p[1] - y)));
        }
    float *rgb = malloc(sizeof(float) * 3 * (size_t)s * s);
    if (!rgb) {
        free(rg);
        cli_error("out of memory");
        return CLI_FAIL;
    }
    for (size_t i = 0; i < (size_t)s * s; i++)
        rgb[3 * i] = rg[2 * i], rgb[3 * i + 1] = rg[2 * i + 1], rgb[3 * i + 2] = 0;
    free(rg);
    envl_result r = png ? envl_png_save_srgb(out, rgb, s, s) : envl_image_save(out, rgb, s, s, NULL);
    free(rgb);
    if (r)
        return cli_fail();
    /* The sidecar. */
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    if (!f) {
        cli_error("out of memory");
        return CLI_FAIL;
    }
    json_writer j;
    json_begin(&j, f);
    json_string(&j, "file", out);
    json_string(&j, "brdf", "GGX, height-correlated Smith visibility, Schlick Fresnel");
    json_string(&j, "alpha", "roughness^2");
    json_int(&j, "size", s);
    json_int(&j, "samples", samples);
    json_bool(&j, "multiscatter", bo.multiscatter);
    json_string(&j, "axes", "column i: NoV = (i + 0.5) / S; row j from the top: roughness = "
                            "(j + 0.5) / S");
    json_string(&j, "channels", bo.multiscatter
                                    ? "R = B, G = A + B: specular = mix(R, G, F0) * (1 + F0 "
                                      "(1 / G - 1))"
                                    : "R = A (scale), G = B (bias): specular = F0 A + B");
    json_string(&j, "encoding", png ? "8-bit sRGB" : "float, blue = 0");
    json_number(&j, "integration_error", err);
    json_number(&j, "seconds", seconds);
    json_end(&j);
    fclose(f);
    char side[4096];
    snprintf(side, sizeof side, "%s.json", out);
    r = envl_file_write_atomic(side, buf, len);
    if (r) {
        free(buf);
        return cli_fail();
    }
    if (json)
        fwrite(buf, 1, len, stdout);
    else
        printf("%s: %d x %d BRDF table%s, %d samples per texel, integration error %.2g (max "
               "against 4x the samples), %.3f s; conventions in %s\n", out, (int)s, (int)s,
               bo.multiscatter ? " (multiscatter)" : "", (int)samples, err, seconds, side);
    free(buf);
    return fflush(stdout) == 0 ? CLI_OK : CLI_FAIL;
}
