/* envlight pov: a POV-Ray 3.7 include with the lights, the ambient and the sky of an
 * environment, for povray_include/envlight.inc's macros. The options become an
 * envl_pov_options; the library (envl_pov_include_write, src/export/pov_include.c) does the
 * rest. Usage errors the options alone show are found here, before the map is read.
 */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const char pov_help[] =
    "Usage: envlight pov [FILE] -o OUT.inc [--scene SCENE.pov] [--recipe R] [--ground ALBEDO]\n"
    "                    [--shadows hard|soft|none] [--sky] [--exposure auto|E]\n"
    "                    [-n N] [--method fit|median|variance] [--order L]\n"
    "                    [--ambient sh|hemi|none] [--sky-image PATH] [--sky-residual]\n"
    "                    [--scene-radius R] [--no-place] [input options]\n"
    "A POV-Ray 3.7 include (POV-Ray's frame: left-handed, +Y up; POV <x,y,z> = canonical\n"
    "<x,z,y>) for povray_include/envlight.inc: light directions and colours (rgb / pi), the\n"
    "ambient that the lights did not take, the sky; then the macro calls that place them.\n"
    "  --scene SCENE     the scene the include is for: what it uses (shadows between\n"
    "                    objects, glossy finishes, a ground plane and its colour, radiosity)\n"
    "                    picks the recipe and the ground; a scene it cannot read is a\n"
    "                    warning and the defaults apply\n"
    "  --recipe R        auto (default: from the scene, see the header's reasons), dome\n"
    "                    (32 or 64 variance-cut lights of the sky, by their error, with\n"
    "                    shadows + radiosity with no sky for the bounces), dome-ambient\n"
    "                    (median-cut lights, 64-256 by their error, + the ground's bounce\n"
    "                    as an ambient, no radiosity), sh (4 fitted lights + SH ambient:\n"
    "                    exact without occlusion),\n"
    "                    image-radiosity (4 fitted lights + the residual sky under\n"
    "                    radiosity); -n/--method/--ambient/--order alone: custom\n"
    "  -n N              lights (custom default 4; dome 32-64; dome-ambient 64-256)\n"
    "  --method M        fit (custom default: lights + SH remainder), median, variance\n"
    "  --order L         SH order of the ambient (fit: of its remainder), 0..8 (default 2);\n"
    "                    fit: -1 fits lights alone (the default with --ambient none)\n"
    "  --ambient A       sh (custom default): the SH ambient as slope-pattern pigments (no\n"
    "                    radiosity needed); hemi: its best sky/ground/axis form; none\n"
    "  --ground A        the scene stands on a ground plane (POV-Ray y = 0) of albedo A\n"
    "                    (0..1): lights, ambient and error are computed from the map with its\n"
    "                    lower hemisphere replaced by the plane's radiance A E_up / pi (E_up:\n"
    "                    the map's exact irradiance at the normal +Z); the ambient then holds\n"
    "                    the plane's bounce and no light comes from below the horizon\n"
    "  --shadows S       hard (default), soft (area lights sized by each light's angular\n"
    "                    diameter), none (shadowless lights)\n"
    "  --sky             declare the environment as a sky_sphere (EnvLight_Sky())\n"
    "  --sky-image PATH  where to write the sky's lat-long .hdr (default: OUT without .inc +\n"
    "                    _sky.hdr; a lat-long .hdr input is used as it is when not given)\n"
    "  --sky-residual    the sky shows the residual (what the lights did not take)\n"
    "  --scene-radius R  lights are placed at 2 R from the scene centre (default 100)\n"
    "  --exposure E      auto or a number: the default of EnvLight_Exposure, which scales\n"
    "                    everything envlight adds (auto: a white surface facing up reads\n"
    "                    0.6, for an 8-bit image; default 1: the map's radiometry)\n"
    "  --no-place        only declare: the scene calls EnvLight_Place_Lights() etc. itself\n"
    "  -o OUT            the include, written atomically (default: stdout)\n"
    "The header states the source, the options, the diffuse error of lights + ambient against\n"
    "the exact integrator and the seconds it took.\n";

/* The options as given, before the library resolves them. */
typedef struct pov_args {
    const char *file, *out;
    envl_pov_options o;
} pov_args;

static int parse_ambient(const char *v, int32_t *out)
{
    static const char *names[] = {"sh", "hemi", "none"};
    static const int32_t values[] = {ENVL_POV_AMBIENT_SH, ENVL_POV_AMBIENT_HEMI,
                                     ENVL_POV_AMBIENT_NONE};
    for (int k = 0; k < 3; k++)
        if (!strcmp(v, names[k]))
            return *out = values[k], 0;
    return -1;
}

static int parse_shadows(const char *v, int32_t *out)
{
    static const char *names[] = {"hard", "soft", "none"};
    static const int32_t values[] = {ENVL_POV_SHADOWS_HARD, ENVL_POV_SHADOWS_SOFT,
                                     ENVL_POV_SHADOWS_NONE};
    for (int k = 0; k < 3; k++)
        if (!strcmp(v, names[k]))
            return *out = values[k], 0;
    return -1;
}

/* One option with a value at argv[*i]: 1 taken, 0 not one of these, CLI_USAGE-style -2 after
 * a usage error. */
static int pov_value_option(int argc, char **argv, int *i, pov_args *a)
{
    envl_pov_options *o = &a->o;
    const char *v;
    long long n;
    int r;
    if ((r = cli_value(argc, argv, i, "-n", &v)) != 0 ||
        (r = cli_value(argc, argv, i, "--count", &v)) != 0) {
        if (r < 0 || cli_parse_int(v, 1, 1 << 16, &n))
            return cli_usage("pov", "-n takes a number of lights, 1..65536"), -2;
        o->count = (int32_t)n;
    } else if ((r = cli_value(argc, argv, i, "--method", &v)) != 0) {
        /* sun: the suns alone (the rest is a residual map, which an include carries only
         * as the image-radiosity recipe's sky): not a light set for POV-Ray on its own */
        if (r < 0 || (o->method = envl_method_from_name(v)) < 0 || o->method == ENVL_METHOD_SUN)
            return cli_usage("pov", "--method takes fit, median or variance"), -2;
        o->method_is_set = 1;
    } else if ((r = cli_value(argc, argv, i, "--recipe", &v)) != 0) {
        /* "custom" is what the low-level options make, not a name to give */
        if (r < 0 || (o->recipe = envl_pov_recipe_from_name(v)) < 0 ||
            o->recipe == ENVL_POV_RECIPE_CUSTOM)
            return cli_usage("pov", "--recipe takes auto, dome, dome-ambient, sh or "
                             "image-radiosity"), -2;
        o->recipe_is_set = 1;
    } else if ((r = cli_value(argc, argv, i, "--scene", &v)) != 0) {
        if (r < 0 || !*v)
            return cli_usage("pov", "--scene needs the scene's .pov file"), -2;
        o->scene_path = v;
    } else if ((r = cli_value(argc, argv, i, "--order", &v)) != 0) {
        if (r < 0 || cli_parse_int(v, -1, ENVL_POV_MAX_ORDER, &n))
            return cli_usage("pov", "--order takes -1..%d", ENVL_POV_MAX_ORDER), -2;
        o->order = (int32_t)n;
        o->order_is_set = 1;
    } else if ((r = cli_value(argc, argv, i, "--ambient", &v)) != 0) {
        if (r < 0 || parse_ambient(v, &o->ambient))
            return cli_usage("pov", "--ambient takes sh, hemi or none"), -2;
    } else if ((r = cli_value(argc, argv, i, "--shadows", &v)) != 0) {
        if (r < 0 || parse_shadows(v, &o->shadows))
            return cli_usage("pov", "--shadows takes hard, soft or none"), -2;
    } else if ((r = cli_value(argc, argv, i, "--scene-radius", &v)) != 0) {
        if (r < 0 || cli_parse_double(v, &o->scene_radius) || !(o->scene_radius > 0) ||
            o->scene_radius > 1e12)
            return cli_usage("pov", "--scene-radius takes a positive number"), -2;
    } else if ((r = cli_value(argc, argv, i, "--ground", &v)) != 0) {
        if (r < 0 || cli_parse_double(v, &o->ground_albedo) ||
            !(o->ground_albedo >= 0 && o->ground_albedo <= 1))
            return cli_usage("pov", "--ground takes the plane's albedo, a number within "
                             "[0, 1]"), -2;
        o->ground_plane = 1;
    } else if ((r = cli_value(argc, argv, i, "--exposure", &v)) != 0) {
        if (r < 0 || (strcmp(v, "auto") && (cli_parse_double(v, &o->exposure) ||
                                            !(o->exposure > 0) || o->exposure > 1e12)))
            return cli_usage("pov", "--exposure takes auto or a positive number"), -2;
        if (!strcmp(v, "auto"))
            o->exposure = ENVL_POV_EXPOSURE_AUTO;
    } else if ((r = cli_value(argc, argv, i, "--sky-image", &v)) != 0) {
        if (r < 0 || !*v)
            return cli_usage("pov", "--sky-image needs a file name"), -2;
        o->sky_image = v;
    } else if ((r = cli_value(argc, argv, i, "-o", &v)) != 0) {
        if (r < 0)
            return cli_usage("pov", "-o needs a file name"), -2;
        a->out = v;
    }
    return r;
}

/* The arguments: CLI_OK, or an exit status (--help: -1, to exit 0). */
static int pov_parse(int argc, char **argv, cli_common *c, pov_args *a)
{
    for (int i = 1; i < argc; i++) {
        const char *s = argv[i];
        int r = cli_common_option("pov", argc, argv, &i, c);
        if (r < 0)
            return CLI_USAGE;
        if (r > 0)
            continue;
        if (!strcmp(s, "--help") || !strcmp(s, "-h")) {
            printf("%s\n%s", pov_help, cli_common_help);
            return -1;
        }
        if ((r = pov_value_option(argc, argv, &i, a)) < 0)
            return CLI_USAGE;
        if (r > 0)
            continue;
        if (!strcmp(s, "--sky"))
            a->o.sky = 1;
        else if (!strcmp(s, "--sky-residual"))
            a->o.sky = a->o.sky_residual = 1;
        else if (!strcmp(s, "--no-place"))
            a->o.no_place = 1;
        else if (s[0] == '-' && s[1])
            return cli_usage("pov", "unknown option '%s'", s);
        else if (a->file)
            return cli_usage("pov", "one FILE only");
        else
            a->file = s;
    }
    return CLI_OK;
}

/* Usage errors the options alone show, before the map is read: -n against the recipe's
 * method (the library's rule: dome variance, dome-ambient median, the others fit; -n makes the
 * recipe custom unless --recipe names one; --recipe auto picks it from the scene, so that is
 * checked on the library's plan), and a sky image without a name (auto never picks
 * image-radiosity). */
static int pov_usage_checks(const pov_args *a)
{
    const envl_pov_options *o = &a->o;
    int picked = a->o.recipe_is_set && o->recipe == ENVL_POV_RECIPE_AUTO && !o->method_is_set;
    envl_lights_options lo = {.count = o->count ? o->count : 4};
    lo.method = o->method_is_set                               ? o->method
                : !o->recipe_is_set                            ? ENVL_METHOD_FIT
                : o->recipe == ENVL_POV_RECIPE_DOME            ? ENVL_METHOD_VARIANCE
                : o->recipe == ENVL_POV_RECIPE_DOME_AMBIENT    ? ENVL_METHOD_MEDIAN
                                                               : ENVL_METHOD_FIT;
    if (!picked && !cli_light_count_ok("pov", &lo))
        return CLI_USAGE;
    int ir = o->recipe == ENVL_POV_RECIPE_IMAGE_RADIOSITY;
    int builtin_sky = !a->file || !strcmp(a->file, "-");
    if ((o->sky || ir) && !o->sky_image && (!a->out || !strcmp(a->out, "-")) &&
        (o->sky_residual || ir || builtin_sky))
        return cli_usage("pov", "--sky needs -o or --sky-image to name the sky image");
    return CLI_OK;
}

/* "envlight pov ARGS...", the header's command line. */
static char *pov_command(int argc, char **argv)
{
    size_t n = strlen("envlight") + 1;
    for (int i = 0; i < argc; i++)
        n += strlen(argv[i]) + 1;
    char *s = malloc(n), *q = s;
    if (!s)
        return NULL;
    q += sprintf(q, "envlight");
    for (int i = 0; i < argc; i++)
        q += sprintf(q, " %s", argv[i]);
    return s;
}

/* The library's warnings, a line each, as messages (unless --quiet). */
static void pov_warnings(const char *w, int quiet)
{
    for (const char *e; w && *w && !quiet; w = e + 1) {
        if (!(e = strchr(w, '\n')))
            e = w + strlen(w);
        cli_error("%.*s", (int)(e - w), w);
        if (!*e)
            break;
    }
}

int cli_pov(int argc, char **argv)
{
    cli_common c = {0};
    pov_args a = {0};
    int rc = pov_parse(argc, argv, &c, &a);
    if (rc < 0)
        return CLI_OK; /* --help */
    if (rc != CLI_OK || (rc = pov_usage_checks(&a)) != CLI_OK)
        return rc;
    char *command = pov_command(argc, argv);
    if (!command) {
        cli_error("pov: out of memory");
        return CLI_FAIL;
    }
    a.o.command = command;
    a.o.source = a.file && strcmp(a.file, "-") ? a.file : "sky";
    a.o.threads = c.load.threads;
    int to_file = a.out && strcmp(a.out, "-");
    envl_envmap *map;
    if (cli_load(a.file, &c, &map)) {
        free(command);
        return CLI_FAIL;
    }
    envl_pov_result res;
    envl_result r = envl_pov_include_write(map, &a.o, to_file ? a.out : NULL, &res);
    pov_warnings(res.warnings, c.quiet);
    envl_lights_options planned = {.method = res.method, .count = res.count};
    if (r == ENVL_ERR_ARGUMENT && !cli_light_count_ok("pov", &planned))
        rc = CLI_USAGE; /* --recipe auto picked a fit for more than 32 lights */
    else if (r)
        rc = cli_fail();
    else if (!to_file && (fputs(res.text, stdout) < 0 || fflush(stdout)))
        rc = CLI_FAIL;
    envl_pov_result_free(&res);
    envl_envmap_free(map);
    free(command);
    return rc;
}
