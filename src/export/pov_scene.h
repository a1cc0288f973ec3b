/* What a POV-Ray scene uses (objects, shadows, gloss, a ground plane, radiosity, a sky), read
 * tolerantly for `envlight pov --scene`. */
#ifndef ENVL_POV_SCENE_H
#define ENVL_POV_SCENE_H

#include <stddef.h>

/* The largest scene file read, in bytes (64 MiB). */
#define POV_SCENE_MAX_BYTES ((size_t)64 << 20)

/* What a POV-Ray scene file uses, read tolerantly for `envlight pov --scene` (no macro
 * expansion, no #include followed: a token scan).
 * Conditionals: every branch is scanned; objects and casters count the branch of each
 * #if / #switch that places the most (one configuration's worth, not their sum). Objects
 * inside #macro bodies are not placed (no expansion); objects inside #while / #for count once.
 * glossy, radiosity and sky look at the whole file, declarations and macro bodies included. */
typedef struct pov_scene {
    int objects;          /* top-level object statements placed in the scene (not those inside #declare/#local) */
    int casters;          /* of those, how many cast shadows (no `no_shadow` in their block) */
    int glossy;           /* some finish has specular, phong, reflection or metallic > 0 (a non-literal value counts as > 0) */
    int ground;           /* a placed plane whose normal is +y: `plane { y, H`, `+y`, `<0, k, 0>` with k > 0 */
    double ground_height; /* its H (0 when not a literal) */
    double ground_albedo; /* its pigment's luminance (0.2126 R + 0.7152 G + 0.0722 B) when written as a literal colour inside the plane's block: `pigment { rgb 0.5 }`, `pigment { color rgb <a, b, c> }`, `pigment { rgb <a,b,c> }`, `EnvLight_Diffuse_Texture(<a, b, c>)` or `(0.5)`; 0 (with a note) when that literal is negative; -1 when not a literal (an identifier, a pattern) or no ground */
    int ground_box;       /* 1: the ground is a box (no plane faces +y): the placed box of literal corners and no transform, at least 4 x wider and deeper than high, of the largest such area; its top is ground_height */
    int radiosity;        /* global_settings contains `radiosity`, or the scene calls EnvLight_Radiosity_Settings / EnvLight_Radiosity_Residual_Settings */
    int sky;              /* the scene shows a sky: `background`, `sky_sphere`, or calls EnvLight_Sky */
    int lights;           /* light_source statements placed (outside #declare / #local and #macro bodies; in conditionals as objects are) */
    int lights_declared;  /* light_source statements inside a #declare / #local (placed only where the scene uses the name) */
    int reflective;       /* some finish has reflection > 0 */
    int double_highlights; /* finishes with reflection > 0 and specular or phong > 0: under a sky their reflection holds the lights' highlights, which POV-Ray adds again */
    int double_line;      /* the line of the first of them (0: none) */
    int includes;         /* #include directives of files other than POV-Ray's standard includes and envlight.inc: their objects, lights and finishes are not read (pov_scene_read: less the first when it is a file envlight wrote) */
    char include_name[128]; /* the first of those files, as written (truncated) */
    char note[256];       /* the first problem met (unbalanced braces, unterminated comment or string, a file it cannot open...), "" when none */
} pov_scene;

/* Reads `path`. Returns 0 when the file was read (whatever its content: the reader never fails
 * on syntax, it notes the first problem in out->note and carries on), -1 when it could not be
 * opened or read (out->note names the file and says why). Never crashes, on any bytes. */
int pov_scene_read(const char *path, pov_scene *out);

/* The scan pov_scene_read runs on the file's bytes: `n` bytes of `text` (NULs allowed, no
 * terminator needed). Fills `out` as pov_scene_read does; never fails. */
void pov_scene_scan(const char *text, size_t n, pov_scene *out);

#endif
