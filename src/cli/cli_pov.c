/* envlight pov: a POV-Ray 3.7 include with the lights, the ambient and the sky of an
 * environment, for povray_include/envlight.inc's macros. The options become an
 * envl_pov_options; the library (envl_pov_include_write, src/export/pov_include.c) does the
 * rest. Usage errors the options alone show are found here, before the map is read.
 */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const cli_command pov_command_help = {
    "pov",
    "Usage: envlight pov [FILE] -o OUT.inc [--scene SCENE.pov] [--recipe R] [--ground ALBEDO]\n"
    "                    [--shadows auto|soft|hard|none] [--sky] [--exposure auto|E]\n"
    "                    [-n N] [--method fit|median|variance] [--order L]\n"
    "                    [--ambient sh|hemi|none] [--sky-image PATH] [--sky-residual]\n"
    "                    [--scene-radius R] [--no-place] [input options]\n"
    "A POV-Ray 3.7 include (POV-Ray's frame: left-handed, +Y up; POV <x,y,z> = canonical\n"
    "<x,z,y>) for povray_include/envlight.inc: light directions and colours (rgb / pi), the\n"
    "ambient that the lights did not take, the sky; then the macro calls that place them.\n",
    "The header states the source, the options, the diffuse error of lights + ambient against\n"
    "the exact integrator and the seconds it took.\n"};

/* The options as given, before the library resolves them. */
typedef struct pov_args {
    const char *file, *out;
    envl_pov_options o;
} pov_args;

/* The arguments: CLI_OK, CLI_HELP or CLI_USAGE. */
static int pov_parse(int argc, char **argv, cli_common *c, pov_args *a)
{
    envl_pov_options *o = &a->o;
    const char *exposure = NULL;
    int order = ENVL_DEFAULT_ORDER, npos;
    cli_option t[] = {
        CLI_OPTION("--scene", "SCENE", CLI_TEXT, .value = &o->scene_path,
                   .takes = "the scene's .pov file",
                   .help = "the scene the include is for: what it uses (shadows between\n"
                           "objects, glossy finishes, a ground plane and its colour, radiosity)\n"
                           "picks the recipe and the ground; a scene it cannot read is a\n"
                           "warning and the defaults apply"),
        CLI_OPTION("--recipe", "R", CLI_CHOICE, .value = &o->recipe,
                   .choices = "auto|dome|dome-ambient|sh|image-radiosity",
                   .lookup = envl_pov_recipe_from_name,
                   .help = "auto (default: from the scene, see the header's reasons), dome\n"
                           "(48 or 64 variance-cut lights of the sky, by their error, with\n"
                           "shadows + radiosity with no sky for the bounces), dome-ambient\n"
                           "(median-cut lights, 64-256 by their error, + the ground's bounce\n"
                           "as an ambient, no radiosity), sh (4 fitted lights + SH ambient:\n"
                           "exact without occlusion), image-radiosity (4 fitted lights + the\n"
                           "residual sky under radiosity); -n/--method/--ambient/--order\n"
                           "alone: custom"),
        CLI_OPTION("-n|--count", "N", CLI_INT, .min = 1, .max = 1 << 16, .value = &o->count,
                   .takes = "a number of lights, 1..65536",
                   .help = "lights (custom default 4; dome 48-64; dome-ambient 64-256)"),
        /* sun: the suns alone (the rest is a residual map, which an include carries only as
         * the image-radiosity recipe's sky): not a light set for POV-Ray on its own */
        CLI_OPTION("--method", "M", CLI_CHOICE, .value = &o->method,
                   .choices = "fit|median|variance",
                   .help = "fit (custom default: lights + SH remainder), median, variance"),
        CLI_OPTION("--order", "L", CLI_INT, .min = -1, .max = ENVL_POV_MAX_ORDER, .value = &order,
                   .help = "SH order of the ambient (fit: of its remainder), 0..8 (default 2);\n"
                           "fit: -1 fits lights alone (the default with --ambient none)"),
        CLI_OPTION("--ambient", "A", CLI_CHOICE, .value = &o->ambient,
                   .choices = "auto|sh|hemi|none",
                   .help = "sh (custom default): the SH ambient as slope-pattern pigments (no\n"
                           "radiosity needed); hemi: its best sky/ground/axis form; none;\n"
                           "auto: the recipe's"),
        CLI_OPTION("--ground", "A", CLI_REAL, .min = 0, .max = 1, .value = &o->ground_albedo,
                   .takes = "the plane's albedo, a number within [0, 1]",
                   .help = "the scene stands on a ground plane (POV-Ray y = 0) of albedo A\n"
                           "(0..1): lights, ambient and error are computed from the map with its\n"
                           "lower hemisphere replaced by the plane's radiance A E_up / pi (E_up:\n"
                           "the map's exact irradiance at the normal +Z); the ambient then holds\n"
                           "the plane's bounce and no light comes from below the horizon"),
        CLI_OPTION("--shadows", "S", CLI_CHOICE, .value = &o->shadows,
                   .choices = "auto|soft|none|hard",
                   .help = "auto (default: the recipe's: a dome's soft, others hard), soft\n"
                           "(area lights: a dome's shaped as its region of the sky, others\n"
                           "a disc of the light's angular diameter), none (shadowless), hard\n"
                           "(points: a dome's shadows then show as rings)"),
        CLI_OPTION("--sky", NULL, CLI_FLAG, .value = &o->sky,
                   .help = "declare the environment as a sky_sphere (EnvLight_Sky())"),
        CLI_OPTION("--sky-image", "PATH", CLI_TEXT, .value = &o->sky_image,
                   .takes = "a file name",
                   .help = "where to write the sky's lat-long .hdr (default: OUT without .inc +\n"
                           "_sky.hdr; a lat-long .hdr input is used as it is when not given)"),
        CLI_OPTION("--sky-residual", NULL, CLI_FLAG, .value = &o->sky_residual,
                   .help = "the sky shows the residual (what the lights did not take)"),
        CLI_OPTION("--scene-radius", "R", CLI_REAL, .min = 1e-300, .max = 1e12,
                   .value = &o->scene_radius, .takes = "a positive number",
                   .help = "lights are placed at 2000 R from the scene centre (default 100)"),
        CLI_OPTION("--exposure", "E", CLI_TEXT, .value = &exposure,
                   .takes = "auto or a positive number",
                   .help = "auto or a number: the default of EnvLight_Exposure, which scales\n"
                           "everything envlight adds (auto: a white surface facing up reads\n"
                           "0.6, for an 8-bit image; default 1: the map's radiometry)"),
        CLI_OPTION("--no-place", NULL, CLI_FLAG, .value = &o->no_place,
                   .help = "only declare: the scene calls EnvLight_Place_Lights() etc. itself"),
        CLI_OPTION("-o", "OUT", CLI_TEXT, .value = &a->out, .takes = "a file name",
                   .help = "the include, written atomically (default: stdout)"),
    };
    int rc = cli_parse(&pov_command_help, t, CLI_COUNT(t), c, argc, argv, &a->file, 1, &npos);
    if (rc)
        return rc;
    /* "custom" is what the low-level options make, not a name to give */
    if (o->recipe == ENVL_POV_RECIPE_CUSTOM)
        return cli_usage("pov", "--recipe takes auto, dome, dome-ambient, sh or image-radiosity, "
                         "not 'custom'");
    o->recipe_is_set = cli_seen(t, CLI_COUNT(t), "--recipe") != NULL;
    o->method_is_set = cli_seen(t, CLI_COUNT(t), "--method") != NULL;
    o->ground_plane = cli_seen(t, CLI_COUNT(t), "--ground") != NULL;
    if (cli_seen(t, CLI_COUNT(t), "--order"))
        o->order = order < 0 ? ENVL_REMAINDER_NONE : order == 0 ? ENVL_ORDER_0 : order;
    if (exposure && strcmp(exposure, "auto") &&
        (cli_parse_double(exposure, &o->exposure) || !(o->exposure > 0) || o->exposure > 1e12))
        return cli_usage("pov", "--exposure takes auto or a positive number, not '%s'",
                         exposure);
    if (exposure && !strcmp(exposure, "auto"))
        o->exposure = ENVL_POV_EXPOSURE_AUTO;
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
    if (rc)
        return rc == CLI_HELP ? CLI_OK : rc;
    if ((rc = pov_usage_checks(&a)) != CLI_OK)
        return rc;
    /* the library checks the sky image it names itself (envl_pov_include_write) */
    const char *inputs[2] = {a.file, a.o.scene_path}, *outputs[2] = {a.out, a.o.sky_image};
    if (cli_outputs_ok(inputs, 2, outputs, 2))
        return CLI_FAIL;
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
