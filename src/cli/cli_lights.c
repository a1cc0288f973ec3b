/* envlight lights: directional lights standing in for the environment. */
#include "cli.h"
#include "json.h"
#include "repair.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const cli_command lights_command = {
    "lights",
    "Usage: envlight lights [FILE] [-n N] [--method fit|median|variance|sun] [--json|--csv]\n"
    "                       [-o OUT] [--residual FILE] [--order L] [--frame blender|gltf]\n"
    "                       [input options]\n"
    "Directional lights that stand in for the environment, in the canonical frame (Blender:\n"
    "+Z up). Each light: direction, rgb = irradiance it delivers at normal incidence (the sum\n"
    "of L dw it took), solid angle of its region and angular diameter (radians).\n",
    "Every result states its diffuse error (relative RMS irradiance error over 1024 normals\n"
    "against the exact integrator; sun: of the lights + the residual map) and the seconds it\n"
    "took.\n"};

/* Light i with its direction in `frame`. */
static void light_in(const envl_lights *ls, int32_t i, int frame, envl_light *l)
{
    envl_lights_get(ls, i, l);
    envl_frame_vector(frame, l->direction, l->direction);
    envl_frame_vector(frame, l->take_direction, l->take_direction);
}

static void write_json(FILE *f, const envl_info *info, const envl_lights *ls, int frame)
{
    envl_lights_summary s;
    envl_lights_get_summary(ls, &s);
    json_writer j;
    json_begin(&j, f);
    json_string(&j, "file", info->file);
    json_string(&j, "frame", cli_frame_label(frame));
    json_string(&j, "method", envl_method_name(s.method));
    json_int(&j, "count", s.count);
    json_numbers(&j, "power", s.power, 3);
    json_array(&j, "lights");
    for (int32_t i = 0; i < s.count; i++) {
        envl_light l;
        light_in(ls, i, frame, &l);
        json_object(&j, NULL);
        json_numbers(&j, "direction", l.direction, 3);
        json_numbers(&j, "rgb", l.rgb, 3);
        json_number(&j, "solid_angle", l.solid_angle);
        json_number(&j, "angle", l.angle);
        json_number(&j, "angle_degrees", l.angle * 180.0 / ENVL_PI);
        double rect[4] = {l.rect[0], l.rect[1], l.rect[2], l.rect[3]};
        json_numbers(&j, "rect", rect, 4);
        json_numbers(&j, "take_direction", l.take_direction, 3);
        json_number(&j, "take_solid_angle", l.take_solid_angle);
        json_number(&j, "take_angle", l.take_angle);
        json_object_end(&j);
    }
    json_array_end(&j);
    json_numbers(&j, "lights_power", s.lights_power, 3);
    json_numbers(&j, "residual_power", s.residual_power, 3);
    int32_t order;
    const double *rem = envl_lights_remainder(ls, &order);
    double *turned = rem ? malloc(sizeof(double) * 3 * (order + 1) * (order + 1)) : NULL;
    if (turned && !envl_sh_to_frame(frame, order, 3, rem, turned)) {
        json_object(&j, "remainder");
        json_int(&j, "order", order);
        json_array(&j, "irradiance");
        for (int32_t i = 0; i < (order + 1) * (order + 1); i++)
            json_numbers(&j, NULL, turned + 3 * i, 3);
        json_array_end(&j);
        json_object_end(&j);
    } else if (rem) {
        json_string(&j, "remainder", "out of memory");
    }
    free(turned);
    json_bool(&j, "no_light", s.no_light);
    json_object(&j, "error");
    json_bool(&j, "measured", s.diffuse_error >= 0);
    json_number(&j, "diffuse", s.diffuse_error >= 0 ? s.diffuse_error : NAN);
    json_object_end(&j);
    json_number(&j, "seconds", s.seconds);
    json_int(&j, "envmap_width", info->width);
    json_int(&j, "envmap_height", info->height);
    repair_json(&j, info);
    json_end(&j);
}

/* One row per light; every row also carries the set's diffuse error (a fraction, as in the
 * JSON; empty when not measured) and seconds, so the CSV states both as every export does. */
static void write_csv(FILE *f, const envl_lights *ls, int frame)
{
    envl_lights_summary s;
    envl_lights_get_summary(ls, &s);
    char err[32] = "";
    if (s.diffuse_error >= 0)
        snprintf(err, sizeof err, "%.9g", s.diffuse_error);
    fputs("x,y,z,r,g,b,solid_angle,angle,diffuse_error,seconds,frame\n", f);
    for (int32_t i = 0; i < envl_lights_count(ls); i++) {
        envl_light l;
        light_in(ls, i, frame, &l);
        fprintf(f, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%s,%.6g,%s\n", l.direction[0],
                l.direction[1], l.direction[2], l.rgb[0], l.rgb[1], l.rgb[2], l.solid_angle,
                l.angle, err, s.seconds, cli_frame_label(frame));
    }
}

static void write_table(FILE *f, const envl_info *info, const envl_lights *ls, int frame)
{
    envl_lights_summary s;
    envl_lights_get_summary(ls, &s);
    char e[64];
    fprintf(f, "%s: %d lights by %s %s%s, %s, %.3f s, frame %s\n", info->file,
            (int)s.count, envl_method_name(s.method),
            s.method == ENVL_METHOD_SUN   ? "split (+ the residual map)"
            : s.method == ENVL_METHOD_FIT ? "least squares"
                                          : "cut",
            s.remainder_order >= 0 ? " + SH remainder" : "",
            cli_error_text(e, sizeof e, "diffuse", s.diffuse_error), s.seconds,
            cli_frame_label(frame));
    if (s.no_light)
        fprintf(f, "no light: the environment is black\n");
    fprintf(f, "%4s  %8s %8s %8s  %11s %11s %11s  %9s %8s\n", "#", "x", "y", "z", "r", "g", "b",
            "omega sr", "angle deg");
    for (int32_t i = 0; i < s.count; i++) {
        envl_light l;
        light_in(ls, i, frame, &l);
        fprintf(f, "%4d  %8.4f %8.4f %8.4f  %11.5g %11.5g %11.5g  %9.3g %8.3f\n", (int)i,
                l.direction[0], l.direction[1], l.direction[2], l.rgb[0], l.rgb[1], l.rgb[2],
                l.solid_angle, l.angle * 180.0 / ENVL_PI);
    }
    fprintf(f, "power %.6g %.6g %.6g = lights %.6g %.6g %.6g + residual %.6g %.6g %.6g\n",
            s.power[0], s.power[1], s.power[2], s.lights_power[0], s.lights_power[1],
            s.lights_power[2], s.residual_power[0], s.residual_power[1], s.residual_power[2]);
}

int cli_lights(int argc, char **argv)
{
    cli_common c = {0};
    const char *file = NULL, *out = NULL, *residual = NULL;
    int method = ENVL_METHOD_FIT, count = 0, order = ENVL_DEFAULT_ORDER, no_error = 0, npos;
    int format = 0, frame = ENVL_FRAME_BLENDER; /* format: 0 table, 1 json, 2 csv */
    cli_option t[] = {
        CLI_OPTION("-n|--count", "N", CLI_INT, .min = 1, .max = 1 << 24, .value = &count,
                   .help = "number of lights (fit: default 4, at most 32; median, variance:\n"
                           "default 16; sun: at most, default 4)"),
        CLI_OPTION("--method", "M", CLI_CHOICE, .value = &method,
                   .choices = "fit|median|variance|sun", .lookup = envl_method_from_name,
                   .help = "fit (default: non-negative least-squares lights + SH remainder),\n"
                           "median (Debevec 2005), variance (variance-minimising cut), sun (the\n"
                           "suns split off exactly: pixels above 50x the mean luminance, one\n"
                           "light per sun; the residual is the map less exactly their excess)"),
        CLI_OPTION("--order", "L", CLI_INT, .min = -1, .max = ENVL_MAX_REMAINDER_ORDER,
                   .value = &order,
                   .help = "fit: SH order of the low-frequency remainder (default 2; -1: none)"),
        CLI_NO_ERROR_OPTION(&no_error),
        CLI_FRAME_OPTION(&frame),
        CLI_OPTION("--json", NULL, CLI_FLAG, .max = 1, .value = &format, .help = "JSON output"),
        CLI_OPTION("--csv", NULL, CLI_FLAG, .max = 2, .value = &format,
                   .help = "CSV output (default: a table)"),
        CLI_OPTION("-o", "OUT", CLI_TEXT, .value = &out, .takes = "a file name",
                   .help = "write the output to OUT (atomically) instead of stdout"),
        CLI_OPTION("--residual", "FILE", CLI_TEXT, .value = &residual, .takes = "a file name",
                   .help = "save the residual environment (what the lights did not take)"),
    };
    int parsed = cli_parse(&lights_command, t, CLI_COUNT(t), &c, argc, argv, &file, 1, &npos);
    if (parsed)
        return parsed == CLI_HELP ? CLI_OK : parsed;
    envl_lights_options lo = {.method = method, .count = count,
                              .remainder_order = order < 0    ? ENVL_REMAINDER_NONE
                                                 : order == 0 ? ENVL_ORDER_0
                                                              : order,
                              .measure = !no_error,
                              .skip_residual = !residual}; /* kept only to be saved */
    if (!cli_light_count_ok("lights", &lo)) /* once every option is read: any order */
        return CLI_USAGE;
    const char *outputs[2] = {out, residual};
    envl_envmap *map;
    if (cli_outputs_ok(&file, 1, outputs, 2) || cli_load(file, &c, &map))
        return CLI_FAIL;
    envl_lights *ls;
    if (envl_lights_compute(map, &lo, &ls)) {
        envl_envmap_free(map);
        return cli_fail();
    }
    envl_info info;
    envl_envmap_info(map, &info);
    envl_lights_summary s;
    envl_lights_get_summary(ls, &s);
    if (s.no_light && !c.quiet)
        cli_error("%s: no light: the environment is black", file ? file : "sky");
    int rc = CLI_OK;
    if (residual &&
        envl_image_save(residual, envl_lights_residual(ls), info.width, info.height, NULL))
        rc = cli_fail();
    cli_output o;
    if (rc == CLI_OK && (rc = cli_output_open(&o, out)) == CLI_OK) {
        if (format == 1)
            write_json(o.f, &info, ls, frame);
        else if (format == 2)
            write_csv(o.f, ls, frame);
        else
            write_table(o.f, &info, ls, frame);
        rc = cli_output_close(&o);
    }
    envl_lights_free(ls);
    envl_envmap_free(map);
    return rc;
}
