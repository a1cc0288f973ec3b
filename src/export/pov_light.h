/* The lights as the POV-Ray include places them: the dome's light set (pov_dome.c) and the
 * shape of each light's shadow, the spread of the sky it stands for (pov_area.c).
 * Not installed. */
#ifndef ENVL_POV_LIGHT_H
#define ENVL_POV_LIGHT_H

#include "envlight.h"

/* A light's grid has n x n lights, n^2 >= its share of the lights' power / POV_AREA_STEP
 * (so no step of a shadow's edge is more than 1/128 of the light: the rings of the old hard dome
 * were steps of 1/32), at least 2 (the samples' cosines follow the region past a normal's
 * horizon) and at most POV_AREA_MAX_SAMPLES a side (docs/pov_scenes.md measured them). */
#define POV_AREA_STEP (1.0 / 128)
#define POV_AREA_MAX_SAMPLES 4
/* A spread under this (radians of the grid's width) is a point: its penumbra is under a pixel. */
#define POV_AREA_MIN_WIDTH 1e-3
/* The grid's lights are no closer than this (radians, half a degree) along its wider axis. */
#define POV_AREA_MIN_SPACING 0.0087
/* Suns split off the sky before the dome's cut (sun_split.c: above 50 x the mean luminance). */
#define POV_DOME_SUNS 4

/* The side of the horizon a light's grid must stay on: a ground plane (z = 0) would shadow the
 * samples below it, which the region it stands for never had. */
enum { POV_SIDE_ANY, POV_SIDE_UP, POV_SIDE_DOWN };

typedef struct pov_light {
    envl_light l;         /* the library's light: direction, rgb (the power it took), rect */
    double colour[3];     /* what it carries as placed (/ pi in POV-Ray): rgb for a point, for
                             a grid rgb x resultant / the grid's own (pov_area.c) */
    double resultant[3];  /* the region's mean resultant along l, (M_c . l) / P_c */
    double axis[2][3];    /* the grid's axes, canonical frame, in gnomonic units (it spans
                             -axis/2 .. axis/2 about l at unit distance); zero: a point */
    int samples;          /* n: an n x n grid of lights; 1: a point */
    int sun;              /* 1: a sun split off the sky (its excess over the split's threshold) */
    int side;             /* POV_SIDE_* */
} pov_light;

/* The region's shape (pov_area.c): from the pixels of `map` inside l->l.rect (for a sun: their
 * excess over `sun_threshold` luminance), the mean resultant along the light's direction per
 * channel and the second moments of the directions (the axes, scaled by their standard
 * deviations); colour = rgb and samples = 1 until pov_area_samples. */
void pov_area_shape(const envl_envmap *map, double sun_threshold, pov_light *l);

/* The grid sizes of a light set: n from each light's share of the set's power (luminance),
 * the axes' widths for that n (an n-point grid over [-w/2, w/2] has variance
 * w^2 (n + 1) / (12 (n - 1))), kept on the light's side of the horizon; then the colour. */
void pov_area_samples(pov_light *lights, int32_t count);

/* What the light delivers to an unshadowed normal n as envlight.inc places it (the grid's
 * lights, each with its own clamped cosine): colour x mean_k max(0, n . s_k). */
void pov_light_irradiance(const pov_light *p, const double n[3], double out[3]);

/* The dome's light set (pov_dome.c): the suns of `upper` (the sky half, at most POV_DOME_SUNS
 * of them) as lights of their own size, the rest of `upper` cut by variance and, when `map` is
 * given (no ground hides its lower half), map - upper cut apart: `count` lights in all, each
 * with its shape and grid. `upper` NULL: the sky half of `map` (of even height) as a window of
 * its rows, and its lower half likewise (no copies). *lights is malloc'd; *suns and *below count the suns and the lights
 * below the horizon. */
envl_result pov_dome_lights(const envl_envmap *upper, const envl_envmap *map, int32_t count,
                            int32_t threads, pov_light **lights, int32_t *n, int32_t *suns,
                            int32_t *below);

#endif
