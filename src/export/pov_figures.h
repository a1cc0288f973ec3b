/* The in-scene error each POV-Ray recipe's header quotes (pov_recipe.c): written by
 * scripts/figures.py --write from docs/scene_bench_pov.json (scripts/scene_bench.py --host pov),
 * checked against it by the test py_figures. Do not edit by hand. */
#ifndef ENVL_POV_FIGURES_H
#define ENVL_POV_FIGURES_H

#define POV_FIGURE_DOME \
    "scenes (a), (b) on 26 maps: objects 1.3 % median, 3.1 % worst; plane 1.2 % median, 2.2 % " \
    "worst; banding 0.31 % median, 0.44 % worst; a user's still life, room and CSG scene on 26 " \
    "maps: worst object 3.6 % median, 24.5 % worst; 8-22x less POV-Ray CPU than the reference " \
    "(scene bench of 2026-11-30)"
#define POV_FIGURE_SH \
    "scenes (a), (b) on 15 maps: objects 19.4 % median, 94.9 % worst; plane 11.0 % median, 43.4 " \
    "% worst; 227-388x less POV-Ray CPU than the reference (scene bench of 2026-11-29)"
#define POV_FIGURE_IMAGE_RADIOSITY \
    "scenes (a), (b) on 15 maps: objects 12.6 % median, 22.6 % worst; plane 4.4 % median, 13.3 % " \
    "worst; a user's still life, room and CSG scene on 4 maps: worst object 16.4 % median, 126.8 " \
    "% worst; 25-36x less POV-Ray CPU than the reference (scene bench of 2026-11-29)"
#define POV_FIGURE_DOME_AMBIENT NULL /* not in the scene bench */
/* from docs/pov_path_traced.json (scripts/pov_path_traced.py) */
#define POV_FIGURE_DOME_PATH_TRACED \
    "against Cycles path tracing of scenes (a), (b) on 26 maps: -0.9 to +0.4 % on average per " \
    "object and plane; the reference of the figure above is itself -0.4 to +1.2 % off, and that " \
    "is in it (docs/pov_path_traced.md, 2026-11-30)"

#endif
