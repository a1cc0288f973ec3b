/* The POV-Ray include's text (envl_pov_include_write, pov_include.c): the header that states
 * the source, the recipe and why, the error and the seconds; the declarations of the lights,
 * the ambient and the sky; envlight.inc and the calls that place them. POV-Ray's frame is
 * left-handed, +Y up: a canonical vector (x, y, z) is written <x, z, y>. */
#include "pov_include_impl.h"
#include "repair.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* A POV-Ray string literal: quotes, with \ and " escaped (pov_string_ok checked first). */
static void pov_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        if (*s == '\\' || *s == '"')
            fputc('\\', f);
        fputc(*s, f);
    }
    fputc('"', f);
}

/* Text inside a // comment: control characters (a newline would end the comment) become '?'. */
static void pov_comment_text(FILE *f, const char *s)
{
    for (const unsigned char *q = (const unsigned char *)s; *q; q++)
        fputc(*q < 0x20 || *q == 0x7f ? '?' : *q, f);
}

/* Canonical (x, y, z) -> POV-Ray <x, z, y>. */
static void pov_vector(FILE *f, const double v[3])
{
    fprintf(f, "<%.9g, %.9g, %.9g>", v[0], v[2], v[1]);
}

static void pov_rgb(FILE *f, const double c[3], double scale)
{
    fprintf(f, "<%.9g, %.9g, %.9g>", c[0] * scale, c[1] * scale, c[2] * scale);
}

static const char *const amb_names[] = {"?", "sh", "hemi", "none"};

/* Source, command, lights and ambient. */
static void text_header(FILE *f, const pov_plan *p, const pov_work *w)
{
    const envl_info *in = &w->info;
    fprintf(f, "// envlight %s: POV-Ray 3.7 include, for povray_include/envlight.inc\n",
            envl_version_string());
    fputs("// source: ", f);
    pov_comment_text(f, p->source);
    fprintf(f, " (%s, %d x %d canonical lat-long, rotated %.9g degrees about +Z)\n", in->format,
            (int)in->width, (int)in->height, in->rotate_degrees);
    char repaired[512];
    if (repair_nonfinite_text(repaired, sizeof repaired, in))
        fprintf(f, "// loaded: %s\n", repaired);
    if (repair_negative_text(repaired, sizeof repaired, in))
        fprintf(f, "// loaded: %s\n", repaired);
    fputs("// command: ", f);
    pov_comment_text(f, p->command);
    static const char *shadow_names[] = {"none", "hard", "soft"};
    fprintf(f, "\n// %d lights by %s%s; ambient %s", (int)w->s.count,
            envl_method_name(w->s.method), w->rem ? " (+ SH remainder)" : "",
            amb_names[p->ambient]);
    if (p->ambient != ENVL_POV_AMBIENT_NONE)
        fprintf(f, " (%s order %d, %d slope terms)",
                w->amb_sh == w->ground_sh ? "the ground's bounce,"
                : w->rem                  ? "fit remainder"
                                          : "residual SH",
                w->amb_order, w->rd.terms);
    fprintf(f, "; shadows %s\n", shadow_names[p->shadows]);
    if (w->ls == NULL && w->nlights > 0) { /* the dome (pov_dome.c) */
        int rays = 0, most = 1;
        for (int32_t j = 0; j < w->nlights; j++) {
            rays += w->lights[j].samples * w->lights[j].samples;
            most = w->lights[j].samples > most ? w->lights[j].samples : most;
        }
        fprintf(f, "// dome: %d sun%s (each a light of its own size), %d cells of the sky by "
                "variance", (int)w->suns, w->suns == 1 ? "" : "s",
                (int)(w->nlights - w->suns - w->below));
        if (w->below)
            fprintf(f, ", %d of the ground half\n//   (cut apart: %s)", (int)w->below,
                    p->ground_box ? "a floor box hides only what it covers"
                                  : "no ground known to hide it");
        fputc('\n', f);
        if (p->shadows == SHADOW_SOFT)
            fprintf(f, "//   soft shadows: each light a grid of up to %d x %d parallel lights "
                    "spread as its region of the sky,\n//   by its share of the light "
                    "(envlight.inc's EnvLight_Area_Light): %d light sources in all\n", most,
                    most, rays);
    }
    if (p->ambient != ENVL_POV_AMBIENT_NONE) {
        fprintf(f, "// ambient %s: least irradiance %.6g in a channel at 4096 normals",
                p->ambient == ENVL_POV_AMBIENT_HEMI ? "(sky/ground: the best fit with both >= 0)"
                : w->amb_sh == w->ground_sh         ? "(the ground's bounce: never negative)"
                : w->sh && w->amb_sh == envl_sh_irradiance(w->sh)
                    ? "(SH window auto: never negative)"
                    : "(the fit's SH remainder, as fitted)",
                w->amb_least);
        if (w->amb_negative)
            fprintf(f, ": NEGATIVE at %d of them (POV-Ray takes light away there)",
                    w->amb_negative);
        fputc('\n', f);
    }
}

/* What was skipped, and why (a line of the recipe's account). */
static void text_skipped(FILE *f, const pov_plan *p)
{
    int recipe = p->recipe, bounce = p->bounce, any = 0;
    fputs("// skipped:", f);
    if (!p->ground_from && recipe != POV_RECIPE_IMAGE_RADIOSITY && !bounce) {
        fputs(" the ground's bounce (no ground plane: --ground ALBEDO or a plane in --scene);", f);
        any = 1;
    }
    if (p->ambient == ENVL_POV_AMBIENT_NONE && recipe != POV_RECIPE_IMAGE_RADIOSITY) {
        fputs(bounce ? " an ambient (the lights take the whole sky, radiosity the bounces);"
                     : " an ambient (the lights take the whole sky);", f);
        any = 1;
    }
    if (recipe == POV_RECIPE_DOME && !bounce) {
        fputs(" radiosity for bounces (one object: nothing to bounce between);", f);
        any = 1;
    }
    if (!p->sky) {
        fputs(" the sky image (not asked for: --sky);", f);
        any = 1;
    }
    if (recipe != POV_RECIPE_IMAGE_RADIOSITY && recipe != POV_RECIPE_DOME) {
        fputs(" radiosity (not needed);", f);
        any = 1;
    }
    if (p->scene && !p->scene->glossy) {
        fputs(" highlights (no glossy finish in the scene);", f);
        any = 1;
    }
    fputs(any ? "\n" : " nothing\n", f);
}

/* The header's account of the recipe: which, why, what the scene gets and what was skipped,
 * and the in-scene error the scene benchmark measured for it. */
static void text_recipe(FILE *f, const pov_plan *p, const pov_work *w)
{
    const pov_scene *scene = p->scene;
    fprintf(f, "// recipe: %s: %s\n", pov_recipe_name(p->recipe), p->why);
    if (p->bounce)
        fputs("//   bounces: radiosity with no sky in it (envlight.inc's "
              "EnvLight_Bounce_Settings()),\n//   the lights' light gathered from the surfaces "
              "it reached (occluded like the lights)\n", f);
    if (w->bounce_reuse > 0)
        fprintf(f, "//   a low sun: it lights a wall facing it %.1fx as much as the whole sky lights "
                   "the ground,\n//   so the bounce pass reuses its samples over %.2f of the scene "
                   "(EnvLight_Bounce_Reuse), not\n//   POV-Ray's 0.2, which spreads the light off "
                   "objects' sunlit sides over the floor\n", w->low_sun, w->bounce_reuse);
    if (p->dome_auto_count && w->s.count) {
        static const int bounce[] = POV_DOME_COUNTS_BOUNCE, ambient[] = POV_DOME_COUNTS_AMBIENT;
        const int *tried = p->bounce ? bounce : ambient;
        int n = p->bounce ? (int)(sizeof bounce / sizeof *bounce)
                          : (int)(sizeof ambient / sizeof *ambient);
        fprintf(f, "//   dome of %d lights: the smallest of ", (int)w->s.count);
        for (int k = 0; k < n; k++)
            fprintf(f, "%s%d", k ? ", " : "", tried[k]);
        fprintf(f, " whose diffuse error is within %.1f %%\n",
                100 * (p->bounce ? POV_DOME_BOUNCE_ERROR : POV_DOME_ERROR));
    }
    if (scene) {
        fprintf(f, "// scene: %d object%s (%d casting shadows)%s%s%s%s", scene->objects,
                scene->objects == 1 ? "" : "s", scene->casters,
                scene->glossy ? ", glossy finishes" : ", matte finishes only",
                !scene->ground ? ", no ground"
                : scene->ground_box ? ", a ground box" : ", a ground plane",
                scene->radiosity ? ", radiosity" : "", scene->sky ? ", a sky of its own" : "");
        if (scene->lights)
            fprintf(f, ", %d light source%s", scene->lights, scene->lights == 1 ? "" : "s");
        /* the include being written is one of them: not counted */
        const char *base = p->out ? strrchr(p->out, '/') : NULL;
        base = base ? base + 1 : p->out;
        int others = scene->includes - (base && !strcmp(scene->include_name, base));
        if (others > 0)
            fprintf(f, "; %d #include file%s not read (what they place is not counted)",
                    others, others == 1 ? "" : "s");
        fputc('\n', f);
    }
    if (!p->place_lights)
        fprintf(f, "// lights: the scene places %d light source%s of its own: envlight's are "
                "declared, not placed,\n//   nor their bounce pass (EnvLight_Place_Lights() "
                "places them: the scene would be lit twice)\n", scene->lights,
                scene->lights == 1 ? "" : "s");
    if (p->shell)
        fputs("// sky: the scene's own sky_sphere or background stays its backdrop; the bounce "
              "pass sees black\n//   in its place (EnvLight_Radiosity_Shell()): the lights "
              "are the sky\n", f);
    if (scene && scene->double_highlights && (p->sky || scene->sky))
        fprintf(f, "// warning: line %d: %d finish%s reflect%s and ha%s specular or phong: the "
                "reflected sky holds the\n//   lights' highlights, which POV-Ray adds again: "
                "set specular 0 and phong 0 in reflective finishes\n", scene->double_line,
                scene->double_highlights, scene->double_highlights == 1 ? "" : "es",
                scene->double_highlights == 1 ? "s" : "", scene->double_highlights == 1 ? "s"
                                                                                        : "ve");
    else if (scene && scene->reflective && !p->sky && !scene->sky)
        fputs("// note: reflective finishes reflect black: --sky puts the map in their "
              "reflections (then give them\n//   specular 0 and phong 0: the reflected sky "
              "holds the lights' highlights)\n", f);
    if (p->ground_from)
        fprintf(f, "// ground: albedo from %s\n", p->ground_from);
    else if (p->ground_box && p->recipe == POV_RECIPE_DOME && p->bounce) /* plan_recipe */
        fputs("// ground: the scene's floor is a box, finite: the map's lower half stays lights "
              "(cut apart), the box\n//   hides what it covers and radiosity bounces it "
              "(--ground A: an endless plane instead)\n", f);
    text_skipped(f, p);
    /* the dome's figures are those of the dome with its bounce pass */
    const char *expected = p->recipe == POV_RECIPE_DOME && !p->bounce
                               ? NULL
                               : pov_recipe_expected_error(p->recipe);
    fprintf(f, "// in-scene error to expect (scene benchmark, not this map): %s\n",
            expected ? expected : "not measured for this recipe");
    const char *traced = expected ? pov_recipe_path_traced(p->recipe) : NULL;
    if (traced)
        fprintf(f, "//   %s\n", traced);
}

/* The ground plane, the error and the seconds; the frames and units. */
static void text_error(FILE *f, const pov_plan *p, const pov_work *w)
{
    const double *g = w->ground_radiance;
    if (p->ground >= 0 && p->bounce) {
        fprintf(f, "// ground plane (canonical z = 0, POV-Ray y = 0), albedo %.9g: the lights "
                "come from the sky\n//   above it; its bounce (albedo * E_up / pi = <%.6g, "
                "%.6g, %.6g> unoccluded) is radiosity's\n", p->ground, g[0], g[1], g[2]);
    } else if (p->ground >= 0) {
        fprintf(f, "// ground plane (canonical z = 0, POV-Ray y = 0), albedo %.9g: the lower "
                "hemisphere\n//   is its radiance albedo * E_up / pi = <%.6g, %.6g, %.6g>; "
                "lights, ambient and\n//   error are those of the map so edited\n", p->ground,
                g[0], g[1], g[2]);
    }
    fprintf(f, "// diffuse error %.4f %% (lights + ambient as written, against the exact "
            "integrator%s,\n//   relative RMS luminance over 1024 normals, unoccluded); "
            "%.3f s\n", 100 * w->error,
            p->bounce ? (p->ground >= 0 ? " of the sky half: the bounces are radiosity's"
                                     : ": the bounces are radiosity's")
                      : "",
            w->seconds);
    fputs("//\n"
          "// Frames: the canonical frame is Blender's (right-handed, +Z up); POV-Ray's is\n"
          "// left-handed, +Y up. A canonical vector (x, y, z) is the POV-Ray vector <x, z, y>.\n"
          "// Sky: the canonical lat-long image has u = 0 -> -X, 0.25 -> +Y, 0.5 -> +X,\n"
          "// 0.75 -> -Y (canonical), i.e. POV-Ray -X, +Z, +X, -Z; a map_type 1 image_map puts\n"
          "// u = 0 at +X, 0.25 at +Z, 0.5 at -X, 0.75 at -Z. They differ by the mirror\n"
          "// x -> -x: EnvLight_Sky() uses `scale <-1, 1, 1>` (= a mirror in z and a half\n"
          "// turn), then `rotate -EnvLight_Sky_Rotate * y` for a --rotate of the source.\n"
          "// Units: a light's rgb is the irradiance it delivers (sum of L dw); its POV-Ray\n"
          "// colour is rgb / pi (a light_source colour C on diffuse 1 gives radiance C cos).\n",
          f);
    if (p->ambient != ENVL_POV_AMBIENT_NONE)
        fputs("// The ambient irradiance E(n) = sum_k sum_l EnvLight_Ambient_Coef[k][l]\n"
              "//   * P_l(EnvLight_Ambient_Direction[k] . n) (P_l Legendre), in POV-Ray's "
              "frame.\n", f);
}

/* The include's guard: POV_GUARD and 16 hex digits of a 64-bit FNV-1a hash of what it declares
 * and places (the text after the guard, but the line of its seconds: the header's command and
 * timing change from run to run, the lighting does not), filled in by pov_text_build.
 * Including the same lighting twice reads it once (its lights are not placed twice); two
 * different includes are both read (one name for every include skipped the second, and its
 * lights were lost without a word). */
#define POV_GUARD "EnvLight_Inc_"
#define POV_GUARD_HOLE "################"
#define POV_SECONDS_LINE "\n#declare EnvLight_Seconds = "

/* FNV-1a, 64 bits, continued from h (Fowler, Noll, Vo; offset basis 14695981039346656037 and
 * prime 1099511628211 from its reference, http://www.isthe.com/chongo/tech/comp/fnv/). */
static uint64_t fnv1a64(uint64_t h, const char *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        h = (h ^ (unsigned char)s[i]) * 1099511628211ull;
    return h;
}

/* text_scene writes the guard and the seconds' line into every include. */
static void fill_guard(char *text, size_t size)
{
    char *body = strstr(text, POV_GUARD POV_GUARD_HOLE), *end = text + size;
    const char *skip = strstr(body, POV_SECONDS_LINE);
    const char *resume = strchr(skip + 1, '\n');
    uint64_t h = fnv1a64(14695981039346656037ull, body, (size_t)(skip - body));
    h = fnv1a64(h, resume, (size_t)(end - resume));
    char hex[17];
    snprintf(hex, sizeof hex, "%016llx", (unsigned long long)h);
    for (char *at = body; at; at = strstr(at, POV_GUARD POV_GUARD_HOLE))
        memcpy(at += strlen(POV_GUARD), hex, 16);
}

/* The declarations about the source, the ground and the scene. */
static void text_scene(FILE *f, const pov_plan *p, const pov_work *w)
{
    fputs("#ifndef (" POV_GUARD POV_GUARD_HOLE ")\n"
          "#declare " POV_GUARD POV_GUARD_HOLE " = 1;\n", f);
    fputs("#declare EnvLight_Source = ", f);
    pov_string(f, p->source);
    fprintf(f, ";\n#declare EnvLight_Rotate = %.9g; // degrees about canonical +Z (POV-Ray +Y)\n",
            w->info.rotate_degrees);
    fprintf(f, "#declare EnvLight_Method = \"%s\";\n", envl_method_name(w->s.method));
    fprintf(f, "#declare EnvLight_Diffuse_Error = %.9g;\n", w->error);
    fprintf(f, "#declare EnvLight_Seconds = %.6g;\n", w->seconds);
    if (p->ground >= 0) {
        fprintf(f, "#declare EnvLight_Ground_Albedo = %.9g;\n", p->ground);
        fputs("#declare EnvLight_Ground_Radiance = ", f);
        pov_rgb(f, w->ground_radiance, 1);
        fputs("; // below the horizon: albedo * E_up / pi\n", f);
    }
    fprintf(f, "#ifndef (EnvLight_Scene_Center) #declare EnvLight_Scene_Center = <0, 0, 0>; "
               "#end\n");
    fprintf(f, "#ifndef (EnvLight_Scene_Radius) #declare EnvLight_Scene_Radius = %.9g; #end\n",
            p->radius);
    fprintf(f, "#ifndef (EnvLight_Shadows) #declare EnvLight_Shadows = %d; #end "
               "// 0 none, 1 hard, 2 soft\n", p->shadows);
    if (w->bounce_reuse > 0)
        fprintf(f, "#ifndef (EnvLight_Bounce_Reuse) #declare EnvLight_Bounce_Reuse = %.9g; #end "
                   "// the bounce pass's maximum_reuse: a low sun\n", w->bounce_reuse);
}

/* One array of the lights' values, a line each: `put` writes light j's. */
static void text_array(FILE *f, const char *name, const char *note, const pov_work *w,
                       void (*put)(FILE *, const pov_light *))
{
    fprintf(f, "#declare %s = array[%d] { // %s\n", name, (int)w->nlights, note);
    for (int32_t j = 0; j < w->nlights; j++) {
        fputs("  ", f);
        put(f, w->lights + j);
        fputs(j + 1 < w->nlights ? ",\n" : "\n", f);
    }
    fputs("};\n", f);
}

static void put_direction(FILE *f, const pov_light *q) { pov_vector(f, q->l.direction); }
static void put_colour(FILE *f, const pov_light *q) { pov_rgb(f, q->colour, 1 / ENVL_PI); }
static void put_rgb(FILE *f, const pov_light *q) { pov_rgb(f, q->l.rgb, 1); }
static void put_solid_angle(FILE *f, const pov_light *q) { fprintf(f, "%.9g", q->l.solid_angle); }
static void put_angle(FILE *f, const pov_light *q) { fprintf(f, "%.9g", q->l.angle * 180 / ENVL_PI); }
static void put_axis1(FILE *f, const pov_light *q) { pov_vector(f, q->axis[0]); }
static void put_axis2(FILE *f, const pov_light *q) { pov_vector(f, q->axis[1]); }
static void put_samples(FILE *f, const pov_light *q) { fprintf(f, "%d", q->samples); }

/* The lights: one array per value; the dome's area lights three more. */
static void text_lights(FILE *f, const pov_work *w)
{
    fprintf(f, "#declare EnvLight_Count = %d;\n", (int)w->nlights);
    if (w->nlights <= 0)
        return;
    text_array(f, "EnvLight_Direction", "unit, towards the light, POV-Ray frame", w,
               put_direction);
    text_array(f, "EnvLight_Colour", "light_source colour = what it delivers at normal "
               "incidence / pi", w, put_colour);
    text_array(f, "EnvLight_Irradiance", "rgb: the power of the light's region (sum of L dw)",
               w, put_rgb);
    text_array(f, "EnvLight_Solid_Angle", "sr, of the region the light took", w,
               put_solid_angle);
    text_array(f, "EnvLight_Angle", "angular diameter, degrees", w, put_angle);
    int area = 0;
    for (int32_t j = 0; j < w->nlights; j++)
        area |= w->lights[j].samples > 1;
    if (!area)
        return;
    text_array(f, "EnvLight_Area_Axis1", "area light axes, POV-Ray frame, at unit distance", w,
               put_axis1);
    text_array(f, "EnvLight_Area_Axis2", "(the grid spans -axis/2 .. axis/2 about the "
               "direction)", w, put_axis2);
    text_array(f, "EnvLight_Area_Size", "grid of N x N samples; 1: a point", w, put_samples);
}

/* The ambient: its SH (or hemispheric form), then its ridge functions. */
static void text_ambient(FILE *f, const pov_plan *p, const pov_work *w)
{
    if (p->ambient == ENVL_POV_AMBIENT_NONE)
        return;
    fprintf(f, "#declare EnvLight_Ambient_Mode = \"%s\";\n", amb_names[p->ambient]);
    if (p->ambient == ENVL_POV_AMBIENT_SH) {
        int n = (w->amb_order + 1) * (w->amb_order + 1);
        fprintf(f, "#declare EnvLight_Ambient_SH_Order = %d;\n", w->amb_order);
        fprintf(f, "// irradiance SH, canonical frame (Blender, +Z up), docs/design.md's basis\n");
        fprintf(f, "#declare EnvLight_Ambient_SH = array[%d] {\n", n);
        for (int j = 0; j < n; j++) {
            fputs("  ", f);
            pov_rgb(f, w->amb_sh + 3 * j, 1);
            fputs(j + 1 < n ? ",\n" : "\n", f);
        }
        fputs("};\n", f);
    } else {
        fputs("#declare EnvLight_Hemi_Axis = ", f);
        pov_vector(f, w->hemi_axis);
        fputs(";\n#declare EnvLight_Hemi_Sky = ", f);
        pov_rgb(f, w->hemi_sky, 1);
        fputs("; // irradiance at n = axis\n#declare EnvLight_Hemi_Ground = ", f);
        pov_rgb(f, w->hemi_ground, 1);
        fputs("; // at n = -axis\n", f);
    }
    const pov_ridge *rd = &w->rd;
    fprintf(f, "#declare EnvLight_Ambient_Terms = %d;\n", rd->terms);
    fprintf(f, "#declare EnvLight_Ambient_Order = %d;\n", rd->order);
    fprintf(f, "#declare EnvLight_Ambient_Direction = array[%d] {\n", rd->terms);
    for (int k = 0; k < rd->terms; k++) {
        fputs("  ", f);
        pov_vector(f, rd->dir[k]);
        fputs(k + 1 < rd->terms ? ",\n" : "\n", f);
    }
    fprintf(f, "};\n#declare EnvLight_Ambient_Coef = array[%d][%d] {\n", rd->terms,
            rd->order + 1);
    for (int k = 0; k < rd->terms; k++) {
        fputs("  {", f);
        for (int l = 0; l <= rd->order; l++) {
            pov_rgb(f, rd->coef[k][l], 1);
            fputs(l < rd->order ? ", " : "", f);
        }
        fputs(k + 1 < rd->terms ? "},\n" : "}\n", f);
    }
    fputs("};\n", f);
}

/* `#include "envlight.inc"`: from POV-Ray's library path (+L) when it is there, else from
 * this build's povray_include/ (so a scene renders without +L). */
static void text_include_envlight(FILE *f)
{
#ifdef ENVL_POV_INCLUDE_DIR
    const char *path = ENVL_POV_INCLUDE_DIR "/envlight.inc";
    if (access(path, R_OK) == 0 && pov_string_ok(path)) {
        fputs("#if (file_exists(\"envlight.inc\"))\n#include \"envlight.inc\"\n#else\n#include ", f);
        pov_string(f, path);
        fputs("\n#end\n", f);
        return;
    }
#endif
    fputs("#include \"envlight.inc\" // POV-Ray's +L: the folder of envlight.inc\n", f);
}

/* The sky, the exposure, envlight.inc and the calls that place everything. */
static void text_tail(FILE *f, const pov_plan *p, const pov_work *w)
{
    if (p->sky) {
        if (w->sky_relative)
            fputs("// POV-Ray 3.7 opens no file name with bytes outside ASCII: the sky image is "
                  "named\n// relative to this include's folder; render from there\n", f);
        fputs("#declare EnvLight_Sky_File = ", f);
        pov_string(f, w->sky_pov);
        fprintf(f, ";%s\n#declare EnvLight_Sky_Rotate = %.9g;\n",
                p->sky_residual ? " // the residual: what the lights did not take" : "",
                w->sky_rotate);
    }
    fprintf(f, "#declare EnvLight_Exposure_Auto = %.9g; // a white surface facing up reads "
            "%.1f\n", w->exposure_auto, POV_AUTO_WHITE);
    if (p->exposure != 0)
        fprintf(f, "#ifndef (EnvLight_Exposure) #declare EnvLight_Exposure = %.9g; #end // "
                "--exposure %s\n", p->exposure < 0 ? w->exposure_auto : p->exposure,
                p->exposure < 0 ? "auto" : "X");
    text_include_envlight(f);
    if (p->place) {
        if (p->place_lights)
            fputs("EnvLight_Place_Lights()\n", f);
        if (p->sky) /* under the bounce's radiosity the sky is for the camera only */
            fputs(p->bounce ? "EnvLight_Sky_Backdrop()\n" : "EnvLight_Sky()\n", f);
        if (p->recipe == POV_RECIPE_IMAGE_RADIOSITY && p->place_lights)
            fputs("global_settings { EnvLight_Radiosity_Residual_Settings() }\n", f);
        if (p->bounce && p->place_lights)
            fputs("global_settings { EnvLight_Bounce_Settings() }\n", f);
        if (p->shell)
            fputs("EnvLight_Radiosity_Shell()\n", f);
    }
    fputs("#end\n", f);
}

envl_result pov_text_build(const pov_plan *p, const pov_work *w, char **text, size_t *size)
{
    FILE *f = open_memstream(text, size);
    if (!f)
        return envl__fail(ENVL_ERR_MEMORY, "pov: out of memory");
    text_header(f, p, w);
    text_recipe(f, p, w);
    text_error(f, p, w);
    text_scene(f, p, w);
    text_lights(f, w);
    text_ambient(f, p, w);
    text_tail(f, p, w);
    int bad = ferror(f);
    if (fclose(f) || bad) {
        free(*text);
        *text = NULL;
        return envl__fail(ENVL_ERR_MEMORY, "pov: out of memory");
    }
    fill_guard(*text, *size);
    return ENVL_OK;
}
